#pragma once
// The adaptive staircase (issue 19 §4; docs/protocols.md, "Staircase"):
// looks for the strength of one degradation at which a measure (e.g. the
// 95th-percentile force) changes by a set fraction from the participant's
// baseline (their median under the baseline setting, e.g. High Fidelity).
//
// The rule is Levitt's (1971) transformed up-down: after `down` trials in a
// row whose measure changed, the strength steps down; after one that did
// not, it steps up. It converges on the strength at which a trial changes
// with probability 0.5^(1/down): 0.5 for 1-down-1-up (the default, the
// strength where the median response crosses the change), 0.707 for
// 2-down-1-up, 0.794 for 3-down-1-up.
//
// Steps: `step` until the first reversal, half of it until the second, a
// quarter from then on. Strengths stay within [min, max].
//
// Stopping rule, whichever comes first:
//   - `reversals` reversals (an even number): the threshold is the mean
//     strength at the reversals after the first two, which were taken with
//     the larger steps (as many peaks as valleys);
//   - three trials in a row at max without a change (the threshold lies
//     above max) or at min with one (it lies below min): no threshold;
//   - `max_trials` trials: the mean of the reversals after the first two if
//     there are at least two of them, else no threshold.
//
// Pure and deterministic: the state after n trials is a function of the
// spec, the baseline and the n (strength, measure) pairs, so a session that
// crashed resumes by replaying what the database holds.
#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hapticlab::protocols {

// The measures a staircase may follow (the metrics CSV's column names).
inline constexpr std::array<std::string_view, 5> kStaircaseMeasures = {
    "force_median_N", "force_p95_N", "completion_time_s", "speed_median_m_per_s", "path_length_m"};

enum class ChangeDirection { kIncrease, kDecrease, kEither };
std::string_view change_direction_name(ChangeDirection d);  // "increase", "decrease", "either"

struct StaircaseSpec {
  std::string field;        // the settings field varied, e.g. "translation.friction.dynamic_level_N"
  std::string task;         // the task its trials run
  std::string measure;      // one of kStaircaseMeasures
  double change = 0.2;      // fraction of the baseline, > 0 and <= 10
  ChangeDirection direction = ChangeDirection::kEither;
  std::string baseline;     // the protocol setting whose trials give the baseline
  double start = 0.0;       // first strength, min <= start <= max
  double step = 0.0;        // first step, > 0
  double min = 0.0, max = 0.0;
  int down = 1;             // 1..3
  int reversals = 8;        // even, 4..30
  int max_trials = 30;      // 5..200: the bound on the staircase's trials
};

// Whether `value` differs from `baseline` (> 0) by the spec's fraction in its direction.
bool is_changed(const StaircaseSpec& spec, double baseline, double value);

struct StaircaseTrial {
  double strength = 0.0;
  double value = 0.0;  // the measure
  bool changed = false;
};

struct StaircaseState {
  std::vector<StaircaseTrial> trials;
  std::vector<double> reversal_strengths;
  double next_strength = 0.0;  // the strength of the next trial (while not finished)
  double step = 0.0;           // the step in use
  bool finished = false;
  std::string stop_reason;     // empty while running
  std::optional<double> threshold;
};

// Replays the rule over the trials run so far, each (strength, measure), in
// the order they ran. `baseline` > 0.
StaircaseState replay_staircase(const StaircaseSpec& spec, double baseline,
                                std::span<const std::pair<double, double>> trials);

}  // namespace hapticlab::protocols
