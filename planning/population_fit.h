#pragma once
// `hapticlab plan calibrate --fit`: the simulated population fitted to the
// calibration set (calibration_set.h) by importance-weighted simulation,
// with its uncertainty (docs/simulation.md, "Fitting the population").
//
// Free parameters (PopulationParams fields): visual_gain_mean,
// consistency_median, force_level_log_sd and novice_force_factor; every
// other field is fixed (population_fit.cc says why).
//
// Method, in four steps:
// 1. A bank of simulated 3-surgeon studies of the thesis' design (Table 3.3,
//    examples/protocols/thesis_as_run.json), `studies_per_design_point` at
//    each of 9 design populations spread over the prior of
//    (visual_gain_mean, consistency_median), with every force level at 1.
//    Each study is analysed the thesis' way; each participant's dissection
//    trials under High Fidelity and No Force Feedback give its mean and peak
//    contact force and its completion time.
// 2. Any population of the prior grid is evaluated on that bank, the same
//    bank for every grid point (common random numbers). Participant-level
//    targets (Wagner's, Bergholz's) by importance weights: the population's
//    trait densities over the mixture of the design populations'. The
//    thesis' targets concern whole 3-surgeon studies, whose weights (a
//    product of three) degenerate: a logistic emulator of each outcome on
//    the study's mean visual gain and mean log consistency, fitted on the
//    bank, averaged over 400 synthetic studies of the population. The
//    force level only scales a participant's forces (checked: the novice
//    check below), so its spread enters analytically: each synthetic study
//    draws its participants' force levels.
// 3. Likelihood: for each event target, the probability that a simulated
//    study of the source's design and size has the published outcome (the
//    thesis targets: the emulator; Wagner's: 400 synthetic 20-participant
//    studies drawn from the weighted bank); for each value target, a Normal
//    density. Their product (a composite likelihood: the targets'
//    correlations are ignored) times a uniform prior on the grid is the
//    posterior.
// 4. Posterior draws, summaries and per-target diagnostics; the Monte Carlo
//    error from a bootstrap of the bank's studies; convergence checks (each
//    failure named with its value).
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "planning/population_file.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

struct PopulationFitOptions {
  int studies_per_design_point = 48;  // 1..1000; the bank has 9 times as many studies (48: the posterior covered, docs/simulation.md)
  std::uint64_t seed = 1;
  double rate_Hz = 250.0;             // of the bank's trials (the rate check compares 1 kHz)
  double max_trial_s = 300.0;
  std::size_t jobs = 0;               // studies simulated at once (0: two per core)
  int posterior_draws = 200;          // kept in the file
  int bootstrap = 20;                 // resamples of the bank for the Monte Carlo error
  int check_studies = 2;              // studies of the rate check and of the novice check each
  std::string command;                // the command line, recorded in the file
};

// What one calibration target came to under the fitted population.
struct TargetDiagnostic {
  CalibrationTarget target;
  // Event: the probability that a study of the source's design has the
  // published outcome; value: the model's value. Posterior mean and 95 %
  // interval over the posterior.
  double mean = 0.0, low95 = 0.0, high95 = 0.0;
  bool met = false;   // event: mean >= 0.05; value: |mean - published| <= 1.96 sd
  std::string note;   // a miss, named with its value
};

struct PopulationFitResult {
  PopulationFile file;
  std::vector<TargetDiagnostic> targets;
  bool converged = false;
  std::vector<std::string> problems;  // why not converged, each with its value
  std::vector<std::string> notes;     // other findings (a parameter at its prior bound, the checks)
  nlohmann::json summary;             // bank size, timed-out trials, ESS, checks, seconds, Monte Carlo errors
};

// Simulates the bank and the checks, then fits. `protocol` must be the
// thesis design (a control, a No Force Feedback setting, both tasks, three
// participants). `progress(stage, done, total)` is called on the calling
// thread at least every 0.2 s while simulating; `stop()` ends it early
// (then throws std::runtime_error "interrupted"). Throws what
// simulate_study throws and std::invalid_argument for bad options.
PopulationFitResult fit_population(const protocols::Protocol& protocol, const PopulationFitOptions& options,
                                   const std::function<void(const std::string&, int, int)>& progress,
                                   const std::function<bool()>& stop);

}  // namespace hapticlab::planning
