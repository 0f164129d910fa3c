#pragma once
// The parts of the population fit (population_fit.h), shared by its stages:
// the priors and the bank's design populations (population_fit.cc), the
// bank and its checks (population_fit_bank.cc), the thesis emulator and
// the grid's posterior (population_fit_grid.cc), the posterior's draws and
// diagnostics (population_fit_posterior.cc) and the convergence checks and
// summary (population_fit_report.cc). Not for use outside planning/.

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/sim/participant.h"
#include "planning/calibration_set.h"
#include "planning/population_file.h"
#include "planning/population_fit.h"
#include "protocols/protocol.h"

namespace hapticlab::planning::population_fit {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using Progress = std::function<void(const std::string&, int, int)>;
using Stop = std::function<bool()>;

// --- the free parameters' grid and priors (population_fit.cc) --------------------

struct Prior {
  const char* name;
  double lo, hi;
  bool log_scale;
  int cells;
  const char* why;
  const char* source;
};

// The free parameters of the grid, in the order visual_gain_mean,
// consistency_median, force_level_log_sd (novice_force_factor is fitted
// apart: it only scales novices' forces, which no grid target sees).
extern const std::array<Prior, 3> kGridPriors;

inline constexpr double kNoviceLo = 1.0, kNoviceHi = 1.6;
extern const char* const kNoviceWhy;
extern const char* const kNoviceSource;

// Cell centres of a uniform grid over [lo, hi] (linear or in log).
std::vector<double> centres(double lo, double hi, int cells, bool log_scale);

// The fixed fields of a fitted population, and why.
PopulationParams fixed_population();
std::vector<FixedParameter> fixed_parameters();

// The design populations of the bank: a 3 x 3 grid over the prior of
// (visual_gain_mean, consistency_median).
std::vector<PopulationParams> design_populations();

// --- the bank (population_fit_bank.cc) -------------------------------------------

// Thesis events, in calibration_targets() order.
enum ThesisEvent : int {
  kNffP95Dissection, kNffP95Clip, kNffMedianClip, kNffTimeDissection, kNffTimeClip, kOthersP95, kSurgeonsP95,
  kThesisEvents
};
constexpr std::array<const char*, kThesisEvents> kThesisTargetIds = {
    "thesis_nff_p95_dissection", "thesis_nff_p95_clip", "thesis_nff_median_clip", "thesis_nff_time_dissection",
    "thesis_nff_time_clip",      "thesis_others_p95",   "thesis_surgeons_p95"};

struct ParticipantData {
  int study = 0;
  double gain = 0.0, consistency = 0.0;
  // The dissecting tool (the cautery) in the dissection, over its complete
  // trials: mean of the trials' mean and largest contact force [N]; mean
  // completion time [s] and mean log completion time.
  double a = kNaN, b = kNaN;  // mean force: High Fidelity, No Force Feedback
  double A = kNaN, B = kNaN;  // peak force
  double tH = kNaN, tN = kNaN, log_tH = kNaN, log_tN = kNaN;
  bool valid = false;
};

struct StudyData {
  int design = 0;
  std::uint64_t seed = 0;
  std::vector<int> participants;  // indices into Bank::participants
  std::array<bool, kThesisEvents> outcome{};  // the thesis' published outcome happened
  // The emulator's features: the participants' mean visual gain and mean
  // log consistency.
  double mean_gain = 0.0, mean_log_consistency = 0.0;
};

struct Bank {
  std::vector<PopulationParams> designs;
  std::vector<ParticipantData> participants;
  std::vector<StudyData> studies;
  int trials_run = 0, trials_timed_out = 0;
  // log of the mixture density of the design populations at each
  // participant's (gain, consistency), and at each study's participants
  std::vector<double> log_q_participant;
};

struct Names {
  std::string control, no_feedback;
};

double mean_of(const std::vector<double>& v);
// The mean and its standard error ({NaN, NaN} for none; the SE NaN for one value).
std::pair<double, double> mean_and_se(const std::vector<double>& v);
std::string fmt(double v, int digits = 3);

double log_trait_density(const PopulationParams& p, double gain, double consistency);

// Runs body(k) for k in [0, n) on `jobs` threads; tick(done) on the calling
// thread every 0.2 s. Rethrows the first exception. stop() ends it early.
void parallel_for(int n, std::size_t jobs, const std::function<void(int)>& body,
                  const std::function<void(int)>& tick, const std::function<bool()>& stop);

// Step 1: `studies_per_design_point` simulated studies of `protocol` at each
// design population, with their participants, thesis events and mixture
// densities. `seeds` gets every study's seed (design-major order).
Bank simulate_bank(const protocols::Protocol& protocol, int participants, const Names& names,
                   const PopulationFitOptions& o, std::vector<std::uint64_t>& seeds, const Progress& progress,
                   const Stop& stop);

// The checks: the central design's first studies again at 1 kHz (does the
// bank's rate change the measures?) and with every participant a novice
// (do forces scale with the force level?).
struct BankChecks {
  // Per participant, 1 kHz minus the bank's rate: log No Force Feedback /
  // High Fidelity ratios of mean force, peak force, completion time; log
  // High Fidelity mean force.
  std::vector<double> d_mean, d_peak, d_time, d_level;
  std::vector<double> d_novice;  // log ratio of the High Fidelity mean force, novice over expert
  int rate_events_same = 0, rate_events = 0;
  double novice_log_ratio = kNaN, novice_se = kNaN;
  double kappa = 1.0;  // forces scale with the force level as level^kappa
};
BankChecks check_bank(const protocols::Protocol& protocol, int participants, const Names& names,
                      const PopulationFitOptions& o, const Bank& bank, const std::vector<std::uint64_t>& seeds,
                      const Progress& progress, const Stop& stop);

// --- the thesis targets' emulator and the grid (population_fit_grid.cc) -----------

constexpr int kEmulatorTerms = 4;
using Features = std::array<double, kEmulatorTerms>;
using Emulator = std::array<Features, kThesisEvents>;

Features features(double mean_gain, double mean_log_consistency);
double predict(const Features& beta, const Features& x);
// Each thesis event's logistic regression on the bank's studies, each
// weighted by study_weight (its multiplicity).
Emulator fit_emulator(const Bank& bank, const std::vector<double>& study_weight);

// Synthetic studies of a population: each participant's (gain,
// consistency) drawn from fixed uniforms, summarized as the emulator's
// features.
constexpr int kSyntheticStudies = 400;
struct SyntheticStudies {
  std::vector<std::array<double, 2>> uniforms;  // per participant of every synthetic study: gain, consistency
  int participants = 3;
  SyntheticStudies(std::uint64_t seed, int per_study);
  std::vector<Features> of(const PopulationParams& p) const;
};

constexpr int kWagnerStudies = 400;
constexpr int kWagnerParticipants = 20;

// Common random numbers of the synthetic Wagner studies: which participant
// (a uniform through the weighted CDF) and its force level (a uniform).
struct Crn {
  std::vector<double> pick, level;
  explicit Crn(std::uint64_t seed);
};

// Per grid point: log-likelihood, each target's value (event probability or
// model value, calibration_targets() order without golahmadi), the effective
// sample sizes, and three population ratios for the report.
struct PointResult {
  double log_likelihood = 0.0;
  std::vector<double> values;
  double ess_participants = 0.0;
  double synthetic_inside = 0.0;  // share of the synthetic studies within the bank's features
  double ratio_mean = kNaN, ratio_peak = kNaN, ratio_time = kNaN;
};

struct GridSpec {
  std::vector<double> gain, consistency, force_sd;
  std::size_t size() const { return gain.size() * consistency.size() * force_sd.size(); }
  // index = (ig * nc + ic) * nf + if
  std::size_t index(std::size_t ig, std::size_t ic, std::size_t jf) const {
    return (ig * consistency.size() + ic) * force_sd.size() + jf;
  }
};

double normal_log_density(double x, double mean, double sd);
// Weighted quantile of values (pairs of value, weight).
double weighted_quantile(std::vector<std::pair<double, double>> v, double q);

// Steps 2 and 3: the grid's posterior (with each grid point's values), and
// the Monte Carlo spread of its marginal means over bootstrap resamples of
// the bank's studies.
struct GridPosterior {
  GridSpec grid;
  std::vector<CalibrationTarget> targets;  // calibration_targets() without golahmadi's
  const CalibrationTarget* golahmadi = nullptr;
  std::vector<PointResult> points;
  std::vector<double> post;
  std::array<std::vector<double>, 3> boot_means;  // per grid parameter, one mean per resample
};
GridPosterior grid_posterior(const Bank& bank, int participants, const PopulationFitOptions& o,
                             const Progress& progress, const Stop& stop);

// --- the posterior's draws and diagnostics (population_fit_posterior.cc) ----------

// The novice factor's own one-dimensional posterior (Golahmadi's ratio
// against factor^kappa).
struct NovicePosterior {
  std::vector<double> grid, post;
};
NovicePosterior novice_posterior(const CalibrationTarget& golahmadi, double kappa);

// Step 4: the posterior's draws (at least 4000, for the summaries), the
// free parameters summarized into `file` with the first
// `posterior_draws` draws kept; `draws` is cut to those.
void draw_population(const GridPosterior& gp, const NovicePosterior& novice, const PopulationFitOptions& o,
                     std::vector<PopulationParams>& draws, PopulationFile& file);

// A free parameter of a population by its place in file.free.
double free_value(const PopulationParams& p, int q);

// Each calibration target under the fitted population.
std::vector<TargetDiagnostic> target_diagnostics(const GridPosterior& gp, const std::vector<PopulationParams>& draws,
                                                 double kappa);

// --- convergence and the summary (population_fit_report.cc) -----------------------

// Whether the bank covers the posterior, the emulator fits, enough
// participants completed and the Monte Carlo error is small: problems and
// notes into `result`, with the figures in result.summary.
void check_convergence(const Bank& bank, const GridPosterior& gp, const std::vector<PopulationParams>& draws,
                       const PopulationFitOptions& o, PopulationFitResult& result);

// The rate and novice checks' notes and figures.
void report_checks(const BankChecks& checks, const PopulationFitOptions& o, PopulationFitResult& result);

// The bank's sizes, the population ratios and the times in result.summary,
// then the fit's record in result.file.fit.
struct FitTimes {
  double seconds = 0.0, bank_s = 0.0, checks_s = 0.0;
};
void summarize(const protocols::Protocol& protocol, const Bank& bank, const GridPosterior& gp,
               const PopulationFitOptions& o, const FitTimes& times, PopulationFitResult& result);

}  // namespace hapticlab::planning::population_fit
