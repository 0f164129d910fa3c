#pragma once
// The population simulated participants are drawn from: the distribution
// of each trait of ParticipantTraits (participant.h). A population is data,
// not code: the fitted one is read from a population file
// (planning/population_file.h, examples/population/), whose parameters
// `hapticlab plan calibrate --fit` estimates from published human data
// (docs/simulation.md, "Fitting the population"). The defaults below are
// the unfitted model: what the model had before any fit.
//
// Traits whose distribution a fit can move are drawn from truncated
// distributions by inverse CDF from one uniform each, so the same seed gives
// the same person's quantiles under any parameters, and their densities are
// available to importance weighting (population_density below):
//   visual_force_gain ~ Normal(visual_gain_mean, visual_gain_sd), truncated to kVisualGainRange
//   log(consistency) ~ Normal(log(consistency_median), consistency_log_sd), truncated to kConsistencyRange
//   log(force_level) ~ Normal(log(novice ? novice_force_factor : 1), force_level_log_sd), truncated to kForceLevelRange
// (force_level_log_sd 0: every expert's force level is exactly 1, a
// novice's novice_force_factor). The other traits have fixed distributions
// (participant.cc).

#include <cstdint>
#include <string>
#include <utility>

namespace hapticlab {

// The participant model the population describes. A population file from
// another model version is refused, never reinterpreted. 1: the model of
// issue 33 and before (unfitted); 2: the first fitted one (issue 35: the
// left hand's first reach, the clip's seen depth and one aim per trial
// fixed; visual noise and novices as traits).
inline constexpr int kParticipantModelVersion = 2;

struct PopulationParams {
  // Seen/true force of the visual force estimate (no unit), mean and SD
  // between people. Valid: mean within kVisualGainRange, sd in (0, 0.5].
  double visual_gain_mean = 0.65;
  double visual_gain_sd = 0.1;
  // Trial-to-trial log-sd of a person's aimed force and movement time (no
  // unit): its median between people and the log-sd of it. Valid: median
  // within kConsistencyRange, log-sd in (0, 1].
  double consistency_median = 0.25;
  double consistency_log_sd = 0.3;
  // Log-sd of the force level between people (no unit), >= 0 and <= 1;
  // 0: every expert at exactly 1.
  double force_level_log_sd = 0.2;
  // A novice's force level over an expert's (no unit), in [1, 2].
  double novice_force_factor = 1.227;
  // Share of novices in the population, in [0, 1].
  double novice_share = 0.0;
  // Log-sd of the slow drift of the visual force estimate (no unit), in
  // (0, 1]; one value for everybody.
  double visual_noise_log_sd = 0.2;

  // Throws std::invalid_argument naming the field, its value and the range.
  void validate() const;
  // The fields as (name, value) pairs in a fixed order, for files and messages.
  static constexpr int kFields = 8;
  std::pair<const char*, double> field(int i) const noexcept;
  // Sets a field by name; false for an unknown name.
  bool set_field(const std::string& name, double value) noexcept;
};

// The model a simulated participant is drawn from, as stored with a session
// (db session.participant_model): the participant model's version and every
// population field, exact ("participant model 2; population
// visual_gain_mean=0.65 visual_gain_sd=0.1 ..."). Equal texts: the same
// model; the file the fields came from is not part of it.
std::string describe_participant_model(const PopulationParams& p);

// Truncation ranges of the fitted traits' distributions.
inline constexpr std::pair<double, double> kVisualGainRange{0.2, 1.0};
inline constexpr std::pair<double, double> kConsistencyRange{0.02, 0.6};
inline constexpr std::pair<double, double> kForceLevelRange{0.3, 3.0};

// Draws of the fitted traits from one uniform in (0, 1) each, by inverse CDF.
double draw_visual_gain(double u, const PopulationParams& p) noexcept;
double draw_consistency(double u, const PopulationParams& p) noexcept;
double draw_force_level(double u, bool novice, const PopulationParams& p) noexcept;

// Log densities of those traits under the population (natural log, with
// respect to the trait itself), for importance weighting between
// populations. -infinity outside the truncation range.
double log_density_visual_gain(double gain, const PopulationParams& p) noexcept;
double log_density_consistency(double consistency, const PopulationParams& p) noexcept;

// Standard normal CDF and its inverse (|error| < 1e-12 after a Newton step).
double standard_normal_cdf(double x) noexcept;
double standard_normal_quantile(double p) noexcept;

}  // namespace hapticlab
