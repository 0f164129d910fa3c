#pragma once
// The thesis' analysis of a whole study database (3.3.5, 3.3.7, 3.4.2,
// Appendix I):
//
//   study DB ─► per trial: task window (events) + per hand: metrics (samples)
//            ─► per participant × task × measure: Friedman across settings,
//               hands as blocks, repetitions as replicates      (Table 3.4)
//            ─► per task × measure: control vs each other setting, Friedman
//               over participant × hand blocks, Šidák level       (3.5, 3.6)
//            ─► per task × measure: all participants at once (Friedman,
//               Durbin or Skillings–Mack on per-cell medians)    (beyond thesis)
//            ─► per participant × task × hand × measure: Pearson r against
//               the trial number                                  (Table 3.7)
//            ─► per task × hand × {force, speed} × setting: KS with the
//               moving block bootstrap                           (Appendix I)
//
// Only complete trials are analysed by default; aborted ones are counted and
// left out (include_aborted takes them in). Planned or running trials have no
// data to analyse and are only counted.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/metrics/device_energy.h"
#include "analysis/metrics/trial_metrics.h"
#include "analysis/stats/correlation.h"
#include "analysis/stats/ks_bootstrap.h"
#include "analysis/stats/percentile.h"
#include "analysis/stats/test_result.h"
#include "protocols/protocol.h"
#include "protocols/staircase.h"
#include "analysis/study/session_conditions.h"
#include "analysis/study/site_balance.h"

namespace hapticlab::db {
class StudyDb;
}

namespace hapticlab::analysis {

enum class Measure { kForceMedian, kForceP95, kCompletionTime, kSpeedMedian, kPathLength };
inline constexpr std::array<Measure, 5> kAllMeasures = {Measure::kForceMedian, Measure::kForceP95,
                                                        Measure::kCompletionTime, Measure::kSpeedMedian,
                                                        Measure::kPathLength};
// "force_median_N", "force_p95_N", "completion_time_s", ... (CSV column names).
const char* measure_column(Measure m);
// "50p force", "95p force", "Time", "50p velocity", "Path length" (Table 3.4 headings).
const char* measure_label(Measure m);
// "N", "s", "m/s", "m".
const char* measure_unit(Measure m);
// Completion time belongs to the trial, the others to one hand.
bool measure_per_hand(Measure m);

// "left" (instrument 0), "right" (instrument 1).
const char* hand_name(int hand);

// How each setting is compared with the control (docs/analysis.md, "Which
// comparison"). Both are always computed; the method decides which one the
// report and the printed tables lead with.
enum class ComparisonMethod {
  kParticipant,  // one value per participant, exact sign-flip test (participant_level.h): the default
  kThesis,       // the thesis' pairwise Friedman, repetitions and hands as replicates (Tables 3.5-3.6)
};
const char* comparison_method_name(ComparisonMethod m);  // "participant", "thesis"
// Throws DataError naming the allowed values.
ComparisonMethod parse_comparison_method(const std::string& name);

struct AnalysisOptions {
  std::optional<std::int64_t> study_id;  // required when the DB holds several studies
  PercentileMethod percentile_method = PercentileMethod::kMatlab;
  bool include_aborted = false;
  double alpha = 0.05;               // per-participant and family-wise level, in (0, 1)
  std::string control_setting;       // empty: the setting named like "High Fidelity"
  double min_force_N = kMinContactForce_N;
  // Kolmogorov–Smirnov with the moving block bootstrap (Appendix I).
  bool ks = true;
  std::size_t ks_resamples = 1000;   // m, >= 1 (the thesis used 1000)
  std::size_t ks_stride = 50;        // keep every k-th sample of a series (speed)
  std::size_t ks_block_length = 10;  // in kept samples, >= 1
  std::uint64_t seed = 1;
  std::size_t cdf_points = 101;      // quantiles kept per trial and hand for the CDF plots: 0 (none) or >= 2
  std::size_t threads = 0;           // trials read and KS comparisons run in parallel; 0: one thread per core
  ComparisonMethod method = ComparisonMethod::kParticipant;

  // Throws DataError naming the field, its value and the allowed range.
  void validate() const;
};

// One trial and both hands' measures.
struct TrialRecord {
  std::int64_t trial_id = 0;
  std::string participant;
  std::string task;
  std::string setting;
  int repetition = 0;
  int block = 0;
  int position = 0;  // trial number in the participant's schedule (3.4.2.2)
  std::string status;
  std::optional<TaskWindow> window;
  std::string problem;  // why the measures are missing, if they are
  // What was left out of a trial that has its measures, and why (updates
  // missing from its samples: a path length or an energy would bridge the
  // gap with one straight step).
  std::string note;
  // Sample chunks left out as damaged (db/chunk_reader.h describe()); the
  // trial's measures are then missing: a hole would bias them silently.
  std::vector<std::string> damaged_chunks;
  std::array<HandMetrics, 2> hands{};
  // Quantiles of |F| and |v| (cdf_points, p = 0..100 evenly), empty
  // when the hand had none; time-order series decimated by ks_stride for the
  // KS bootstrap.
  std::array<std::vector<double>, 2> force_quantiles_N;
  std::array<std::vector<double>, 2> speed_quantiles_m_per_s;
  std::array<std::vector<double>, 2> force_series_N;
  std::array<std::vector<double>, 2> speed_series_m_per_s;
  // The energy the device and the engine exchanged with each hand over the
  // whole trial (device_energy.h); empty when not read (a damaged chunk,
  // or a simulated study, which keeps only the window's channels).
  std::array<std::optional<HandEnergy>, 2> energy;

  // The measure's value for a hand (ignored for completion time); NaN when missing.
  double value(Measure m, int hand) const;
};

struct TrialCounts {
  std::size_t analysed = 0;           // trials whose data entered the analysis
  std::size_t complete = 0;           // status complete
  std::size_t aborted_excluded = 0;   // left out (default)
  std::size_t aborted_included = 0;   // taken in with include_aborted
  std::size_t not_run = 0;            // planned or running: no data
  std::size_t without_window = 0;     // analysed, but no task window (measures missing)
  std::size_t damaged_chunks = 0;     // sample chunks left out as damaged (their trials are without window)
  std::size_t staircase = 0;          // adaptive staircase trials (block 0): reported apart, not compared
};

// A test that may not be possible; `note` says why when result is empty.
struct OptionalTest {
  std::optional<TestResult> result;
  std::string note;
  std::size_t replicates = 0;        // per cell after balancing (Friedman)
  std::size_t dropped = 0;           // observations dropped to balance replicates
  std::vector<std::string> settings; // settings that entered the test
  // Effect size of a Friedman result: Kendall's W in [0, 1]
  // (stats/effect_size.h; with replicates, the statistic over its maximum).
  std::optional<double> kendalls_w;
};

// Table 3.4 (hand == -1: hands as blocks; 0 / 1: that hand alone).
struct FriedmanRow {
  std::string participant;
  std::string task;
  Measure measure = Measure::kForceMedian;
  int hand = -1;
  OptionalTest test;
};

// Tables 3.5 / 3.6: one cell.
struct PairwiseCell {
  std::string task;
  std::string setting;  // compared with the control
  Measure measure = Measure::kForceMedian;
  std::optional<double> p;
  std::optional<double> statistic;
  std::size_t blocks = 0;
  std::size_t participants = 0;  // the number in brackets in the thesis
  bool significant = false;      // p < Šidák level
  bool gated = false;            // no participant's Table 3.4 test was significant
  std::string note;
  // Effect size: matched-pairs rank-biserial correlation over the blocks of
  // the test (each block's median under the setting minus its median under
  // the control), in [-1, 1]; direction "higher", "lower" or "equal" than
  // the control.
  std::optional<double> rank_biserial;
  std::string direction;
};

// Each setting against the control with one value per participant
// (participant_level.h): one cell.
struct ParticipantPairwiseCell {
  std::string task;
  std::string setting;  // compared with the control
  Measure measure = Measure::kForceMedian;
  std::size_t participants = 0;      // who did both (with data)
  std::optional<double> p;           // two-sided; empty when no participant did both
  std::optional<double> mean_difference;  // setting minus control, in the measure's unit; empty without a test
  bool significant = false;          // p < the study's Šidák level
  std::string note;
};

// Median and interquartile range of a measure under one setting in one
// task, every analysed trial (and hand) pooled: what the p values are about.
struct DescriptiveRow {
  std::string task;
  std::string setting;
  Measure measure = Measure::kForceMedian;
  std::size_t n = 0;  // values (trials x hands for per-hand measures)
  double median = 0.0, q1 = 0.0, q3 = 0.0;  // in the measure's unit; NaN when n == 0
};

struct WholeDesignRow {
  std::string task;
  Measure measure = Measure::kForceMedian;
  OptionalTest test;  // result.method says which test fitted the design
};

struct CorrelationRow {
  std::string participant;
  std::string task;
  Measure measure = Measure::kForceMedian;
  int hand = -1;  // -1 for completion time (both hands)
  std::optional<CorrelationResult> result;
  std::string note;
  std::vector<double> trial_numbers;  // x, for the scatter plot
  std::vector<double> values;         // y
  std::vector<std::string> settings;  // per point
};

struct KsRow {
  std::string task;
  int hand = 0;
  std::string quantity;  // "force" or "speed"
  std::string setting;
  std::optional<KsBootstrapResult> result;  // d_intra / d_inter cleared to keep it small
  std::string note;
};

// A dose-response study's series (protocol "dose", docs/protocols.md): the
// control and one setting per strength of one settings field.
struct DoseLevel {
  std::string setting;
  double strength = 0.0;  // in the field's unit; the control's is 0 when its effect is off
};
struct DoseSeries {
  std::string field;              // e.g. "translation.friction.dynamic_level_N"
  std::vector<DoseLevel> levels;  // the control first, then by increasing strength
};

// One participant's dose-response in one task and measure.
struct DoseParticipantFit {
  std::string participant;
  std::vector<double> medians;  // per level of the series: the median of the repetitions (and hands); NaN without data
  std::optional<double> slope;  // least-squares slope over the levels with data, measure unit per field unit; empty with < 2 levels
};

// The dose-response of one task and measure (dose_response.h).
struct DoseResponseRow {
  std::string task;
  Measure measure = Measure::kForceMedian;
  std::vector<DoseParticipantFit> participants;
  std::vector<double> level_medians;  // per level: the median over participants of their medians; NaN without data
  // The trend: every participant's slope, tested against 0 with the exact
  // sign-flip test over participants (two-sided), at the study's alpha.
  std::optional<double> trend_p;
  double mean_slope = 0.0;
  std::size_t slopes = 0;  // participants with a slope
  bool trend_significant = false;
  // Each strength against the control (the participant-level p of
  // participant_pairwise, index 0 empty for the control) and the minimum
  // effective strength by the fixed-sequence step-down at alpha: empty when
  // even the strongest is not significant.
  std::vector<std::optional<double>> p_vs_control;
  std::optional<double> smallest_significant_strength;
  std::string note;
};

// One participant's adaptive staircase (staircase_progress.h), as analyze
// reports it. Its trials (block 0) are not in the designed comparisons.
struct StaircaseRow {
  std::string participant;
  double baseline = 0.0;            // the measure's median over the baseline trials
  std::size_t baseline_trials = 0;
  std::vector<protocols::StaircaseTrial> trials;  // complete ones, in order
  std::vector<double> reversals;    // strengths
  bool finished = false;
  std::string stop_reason;
  std::optional<double> threshold;
  std::string note;                 // why there is no staircase (e.g. no baseline)
};

struct StudyAnalysis {
  AnalysisOptions options;
  std::filesystem::path db_path;
  std::int64_t study_id = 0;
  std::string study_name;
  // Provenance of the study, as its database stores it.
  std::uint64_t study_seed = 0;
  std::string study_software_version;  // the version that created the study
  std::string protocol_sha256;         // lower-case hex
  std::string study_created_utc;       // ISO 8601
  std::string control;                    // the control setting's name
  std::vector<std::string> tasks;         // in schedule order
  std::vector<std::string> participants;  // in schedule order
  std::vector<std::string> settings;      // study order, control first
  std::vector<TrialRecord> trials;        // analysed trials, by participant then position
  TrialCounts counts;
  double sidak_level = 0.0;
  std::size_t sidak_m = 0;
  std::vector<FriedmanRow> friedman;      // hands as blocks, then per hand
  std::vector<PairwiseCell> pairwise;                         // the thesis' procedure
  std::vector<ParticipantPairwiseCell> participant_pairwise;  // one value per participant
  std::vector<WholeDesignRow> whole_design;
  std::vector<CorrelationRow> correlations;
  std::vector<KsRow> ks;
  std::vector<DescriptiveRow> descriptive;
  std::optional<DoseSeries> dose;               // a dose-response study's series; empty otherwise
  std::vector<DoseResponseRow> dose_response;   // per task x measure, when `dose` is set
  std::optional<protocols::StaircaseSpec> staircase;  // a staircase study's rule; empty otherwise
  // A between-group design's protocol (protocols/transfer_design.h), read
  // from the stored protocol text; empty for a within-participant study.
  // Its comparisons are group_design.h's, not the tables above.
  std::optional<protocols::Protocol> group_design;
  std::vector<StaircaseRow> staircases;               // per participant who has its task
  // A merged multi-site study (db/study_merge.h): each participant's site,
  // from their sessions' `site` (empty map for a study never merged), and
  // per task the site x setting table with its verdict (site_balance.h).
  std::map<std::string, std::string> participant_sites;
  std::vector<SiteBalance> site_balance;
  // The loop rate and who held the device, over the study's sessions, with
  // a warning for each that differs between them (session_conditions.h).
  SessionConditions session_conditions;
};

// Reads the study (options.study_id, or the only one) and runs everything.
// Throws DataError for invalid options, no or several studies without an id,
// or an unknown control; db errors propagate as db::DbError.
StudyAnalysis analyze_study(db::StudyDb& db, const AnalysisOptions& options);

// Opens `db_path` read-only-in-spirit (no recovery, quick integrity check),
// then analyze_study. Throws DataError naming the path if it does not exist.
StudyAnalysis analyze_study_file(const std::filesystem::path& db_path, const AnalysisOptions& options);

// The control: options.control_setting, or the setting named like "High
// Fidelity"; it is moved to the front of a.settings (the rest keep their
// order). Throws DataError naming the settings when there is none, ending
// with `remedy` (what the caller's user can do: analyze has --control, a
// plan command finds the control by its name).
inline constexpr std::string_view kControlOptionRemedy = "name the control with --control";
inline constexpr std::string_view kPlanControlRemedy =
    "plan commands find the control by that name: name the reference setting 'High Fidelity' in the protocol";
void choose_control(StudyAnalysis& a, const AnalysisOptions& options,
                    std::string_view remedy = kControlOptionRemedy);

}  // namespace hapticlab::analysis
