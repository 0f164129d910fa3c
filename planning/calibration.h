#pragma once
// `hapticlab plan calibrate`: does the simulated population show the
// effects published for real people? A calibration protocol (a complete
// design with the control, High Fidelity, and No Force Feedback) is run for
// many simulated participants, and each effect below is measured per
// participant (a ratio of their medians), then summarized over them beside
// the published value. Nothing here tunes the model: the table says where
// it matches a source and where it does not (docs/simulation.md,
// "Calibration").
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "analysis/study/study_analysis.h"
#include "planning/simulated_study.h"

namespace hapticlab::planning {

// One published effect the population should show.
struct PublishedEffect {
  std::string id;        // calibration.csv's key, e.g. nff_force_p95_dissection
  std::string what;      // what is compared, in words
  std::string task;      // "dissection", "clip"
  analysis::Measure measure = analysis::Measure::kForceP95;
  // kSettingRatio: No Force Feedback over the control, both hands pooled.
  // kHandRatio: left over right hand, every setting pooled (as the thesis' Figures 3-11, 3-12).
  enum class Kind { kSettingRatio, kHandRatio } kind = Kind::kSettingRatio;
  std::string published;  // the source's finding, in its words
  std::string source;     // author, year, where
  // How the measured median ratio is judged against the source: the ratio
  // at least `low` (and at most `high`, when high > 0).
  double low = 0.0, high = 0.0;
  std::string criterion;  // the same in words
};

// The table of docs/simulation.md, "Calibration".
const std::vector<PublishedEffect>& published_effects();

struct MeasuredEffect {
  PublishedEffect effect;
  std::size_t participants = 0;   // with data for both sides of the ratio
  double median = 0.0;            // of the participants' ratios
  double q1 = 0.0, q3 = 0.0;      // quartiles of the ratios
  double share_above_one = 0.0;   // participants whose ratio is > 1
  bool consistent = false;        // median within the effect's [low, high]
};

// Participants are simulated in studies of this many (one study per thread
// at a time), each with its own seed, so the population does not depend on
// how many threads run.
inline constexpr int kCalibrationGroup = 10;

struct SimulatedPopulation {
  analysis::StudyAnalysis analysis;  // every group's trials; participants coded "sK/P01" (group K)
  int trials_timed_out = 0;          // left out, as session run would
};

// `participants` simulated participants of `protocol` in groups of
// `group_size` (study k's seed: study_seed(seed, participants, k)), on
// `jobs` threads (0: two per core). `progress(done)` is called on the
// calling thread with the participants simulated so far, at least every
// 0.2 s; `stop()` ends it early (the result is then incomplete). Throws
// what simulate_study throws.
SimulatedPopulation simulate_population(const protocols::Protocol& protocol, int participants, std::uint64_t seed,
                                        std::size_t jobs, const SimulatedStudyOptions& options, int group_size,
                                        const std::function<void(int)>& progress,
                                        const std::function<bool()>& stop);

// Every effect of published_effects() that `analysis` has data for.
// `control` and `no_feedback` name the two settings of the setting ratios.
std::vector<MeasuredEffect> measure_effects(const analysis::StudyAnalysis& analysis, const std::string& control,
                                            const std::string& no_feedback);

// The two settings of the setting ratios, found in a calibration protocol.
struct CalibrationSettings {
  std::string control;      // analysis::choose_control's
  std::string no_feedback;  // the first setting that displays no force
};

// Checks a calibration protocol before anything runs: it has a control
// (analysis::choose_control under `sim`'s analysis options) and a setting
// that displays no force (No Force Feedback by what it does, not its
// name: tip_force_saturation enabled with limit_N 0), that the control is
// undegraded (undegraded_control.h), and that its design takes
// the group sizes of `participants` (resized_protocol with `seed`). Throws
// std::runtime_error naming `protocol_path` and what is missing.
CalibrationSettings check_calibration_protocol(const protocols::Protocol& protocol, const std::string& protocol_path,
                                               int participants, std::uint64_t seed,
                                               const SimulatedStudyOptions& sim);

// calibration.csv: one line per measured effect.
std::string calibration_csv(const std::vector<MeasuredEffect>& effects);

}  // namespace hapticlab::planning
