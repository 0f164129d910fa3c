#pragma once
// A whole study on the simulated rig, held in memory: the protocol's design
// and schedules for any number of fresh participants, every session run on
// the virtual clock exactly as `hapticlab session run` would run it
// (training, trial seeds, practice), each trial's samples turned into its
// measures as they would be read back from the database, then the study's
// statistics. No sample is stored: a thesis-sized study runs in seconds, so
// thousands of them can say what a design can detect (planning/power.h).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <map>

#include "analysis/study/study_analysis.h"
#include "core/sim/population.h"
#include "protocols/protocol.h"

namespace hapticlab::planning {

struct SimulatedStudyOptions {
  double rate_Hz = 1000.0;     // the loop rate of every trial, 150..2000
  double max_trial_s = 300.0;  // per-trial time limit, as session run's --max-trial-s
  // The population the participants are drawn from (core/sim/population.h).
  PopulationParams population;
  // Also measure each trial's mean and largest tip force (force_extremes).
  bool force_extremes = false;
  // The analysis (thesis procedure). Default: no KS bootstrap and no CDF
  // quantiles, which a power estimate does not use.
  analysis::AnalysisOptions analysis = default_analysis();

  static analysis::AnalysisOptions default_analysis() {
    analysis::AnalysisOptions o;
    o.ks = false;
    o.cdf_points = 0;
    return o;
  }
};

// The protocol with `participants` participants coded P01, P02, ... (P001
// from 100 on): participant i takes the tasks and training of the protocol's
// participant i mod m (m its participant count) and, in an explicit design,
// that participant's settings; `seed` replaces the protocol's seed. Throws
// ProtocolError if the result is not a valid protocol (e.g. an incomplete
// design that cannot be balanced for that many participants).
protocols::Protocol resized_protocol(const protocols::Protocol& protocol, int participants, std::uint64_t seed);

// The trials of one task under one setting: how many ran, and how many of
// them timed out (left out of the analysis, as `analyze` leaves out aborted
// trials): a setting under which the task often cannot be finished says so
// here, not in its measures.
struct SettingTrials {
  std::string task;
  std::string setting;
  int run = 0;
  int timed_out = 0;
};

// A trial's mean and largest |tip force| per hand [N] over its task window,
// samples in contact only (>= 1 mN, as the thesis' force measures): what
// Wagner et al. (2002) call the average and the peak force. NaN for a hand
// without contact.
struct TrialForceExtremes {
  std::array<double, 2> mean_N{0.0, 0.0};
  std::array<double, 2> max_N{0.0, 0.0};
};

struct SimulatedStudy {
  analysis::StudyAnalysis analysis;  // trials (their measures) and every statistics table
  // With options.force_extremes: by trial id, complete trials only.
  std::map<std::int64_t, TrialForceExtremes> force_extremes;
  int trials_run = 0;
  int trials_timed_out = 0;      // reached max_trial_s: aborted, left out as session run would
  int training_trials = 0;
  std::uint64_t updates = 0;     // haptic-loop updates simulated (trials and training)
  std::vector<SettingTrials> setting_trials;  // per task and setting, in the order first run
};

// Plans resized_protocol(protocol, participants, seed) and runs it.
// Throws ProtocolError, std::invalid_argument (options), SettingsError.
SimulatedStudy simulate_study(const protocols::Protocol& protocol, int participants, std::uint64_t seed,
                              const SimulatedStudyOptions& options);

}  // namespace hapticlab::planning
