#pragma once
// What a design can detect, found by running it many times on the
// simulated rig (simulated_study.h): for each number of participants,
// `studies` complete studies with fresh seeds, each analysed the thesis'
// way; the share of studies in which a comparison reaches significance is
// its power (or, for a setting that changes nothing, its false-positive
// rate), with a Wilson 95 % interval.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "analysis/study/study_analysis.h"
#include "planning/simulated_study.h"
#include "planning/study_change.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

// One test of one simulated study.
struct Finding {
  // "pairwise": the setting against the control over all participants
  // (Tables 3.5-3.6), significant at the Šidák level and, as the thesis
  // did, only where some participant's Table 3.4 test was significant.
  // "participant_pairwise": the setting against the control with one value
  // per participant (analysis/study/participant_level.h), Šidák level.
  // "participant": one participant's Friedman across settings (Table 3.4,
  // hands as blocks); `setting` is empty.
  std::string method;
  std::string task;
  std::string setting;
  std::string measure;  // metrics.csv column, e.g. force_p95_N
  std::string participant;  // "participant" findings only
  bool significant = false;
  double p = 0.0;  // tests that could not be computed (no data) are not findings
};

// One simulated participant's staircase (a staircase protocol).
struct StaircaseOutcome {
  std::string participant;
  std::optional<double> threshold;  // in the staircase field's unit; empty when none was found
  int trials = 0;                   // staircase trials with the measure
};

struct StudyOutcome {
  int participants = 0;
  int index = 0;  // 0-based study number for this participant count
  std::uint64_t seed = 0;
  int trials_run = 0;
  int trials_timed_out = 0;
  std::uint64_t updates = 0;
  double seconds = 0.0;  // wall time to simulate and analyse it
  std::vector<Finding> findings;
  std::vector<StaircaseOutcome> staircases;  // a staircase protocol's, per participant
  std::vector<ChangeOutcome> changes;        // each setting's change against the control (study_change.h)
  std::vector<SettingTrials> setting_trials;  // trials run and timed out per task and setting
};

// The study seed of study `index` with `participants` participants under
// the run's `seed`: a pure function, so a resumed or re-run plan simulates
// the same studies.
std::uint64_t study_seed(std::uint64_t seed, int participants, int index);

// Every finding of an analysed study.
std::vector<Finding> findings_of(const analysis::StudyAnalysis& analysis);

// Simulates and analyses one study.
StudyOutcome run_power_study(const protocols::Protocol& protocol, int participants, int index, std::uint64_t seed,
                             const SimulatedStudyOptions& options);

// With the model's uncertainty, studies are dealt to this many groups
// (study index mod kDrawGroups), and every study of a group draws its
// participants from one posterior draw of the fitted population: the
// spread of the groups' power estimates, beyond what their sampling
// explains, is the spread of the power over what is not known about the
// model.
inline constexpr int kDrawGroups = 20;
int draw_group(int index);
// The posterior draw (of `draws`) a group uses.
std::size_t draw_of_group(int group, std::size_t draws);

// One line of the power table: the share of studies (or, for
// "participant", of participant tests) that reached significance.
struct PowerRow {
  int participants = 0;
  std::string method;
  std::string task;
  std::string setting;
  std::string measure;
  int significant = 0;
  int tests = 0;
  double rate = 0.0;
  double wilson_low = 0.0;  // 95 % Wilson score interval: the simulation's sampling only
  double wilson_high = 0.0;
  // With the model's uncertainty (summarize_power's draw_groups > 1): a
  // 95 % interval of the power over the fitted population's posterior,
  // sampling included. NaN otherwise.
  double model_low = std::numeric_limits<double>::quiet_NaN();
  double model_high = std::numeric_limits<double>::quiet_NaN();
};

// Rows sorted by participants, method, task, setting (protocol order), measure.
// draw_groups > 1: the studies were dealt to that many posterior draws by
// draw_group(index); each row gets the model-uncertainty interval: the
// between-group variance of the groups' rates, less what their binomial
// sampling explains (method of moments, at least 0, tau^2); its 1.96 tau
// is added in quadrature to each half-width of the Wilson interval, clipped
// to [0, 1]: never narrower than the Wilson interval, equal to it when the
// groups agree (also at a rate of 0 or 1, where the normal approximation
// would give an interval of no width).
std::vector<PowerRow> summarize_power(const std::vector<StudyOutcome>& outcomes,
                                      const std::vector<std::string>& setting_order, int draw_groups = 1);

// The family-wise false-positive rate of each method: the share of studies
// in which at least one comparison of a null setting (a copy of the control
// under another name: nothing differs but the name) came out significant,
// over every task, for one measure.
struct FalsePositiveRow {
  int participants = 0;
  std::string method;
  std::string measure;
  int with_false_positive = 0;
  int studies = 0;
  double rate = 0.0;
  double wilson_low = 0.0;
  double wilson_high = 0.0;
};
std::vector<FalsePositiveRow> false_positive_rates(const std::vector<StudyOutcome>& outcomes,
                                                   const std::set<std::string>& null_settings);

// How well a staircase study measures the threshold, per participant
// count: the share of staircases that ended with a threshold (Wilson 95 %),
// the thresholds' mean and spread between participants, and the spread of a
// study's mean threshold between studies (what a study of that size can
// tell).
struct StaircaseSummaryRow {
  int participants = 0;
  int studies = 0;
  int staircases = 0;
  int with_threshold = 0;
  double rate = 0.0, wilson_low = 0.0, wilson_high = 0.0;
  double mean_threshold = 0.0;          // over every threshold found; NaN when none
  double sd_between_participants = 0.0;  // sample SD of those thresholds; NaN with fewer than 2
  double sd_of_study_means = 0.0;        // sample SD of each study's mean threshold; NaN with fewer than 2 studies with one
  double mean_trials = 0.0;              // staircase trials per participant
};
std::vector<StaircaseSummaryRow> summarize_staircases(const std::vector<StudyOutcome>& outcomes);

}  // namespace hapticlab::planning
