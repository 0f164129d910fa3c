#include "protocols/staircase.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>

namespace hapticlab::protocols {
namespace {

// Steps add up in binary: 0.9 - 0.2 is 0.7000000000000001. Strengths name
// settings, so they are kept at 12 significant digits.
double tidy(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.12g", x);
  return std::strtod(buf, nullptr);
}

constexpr int kBoundTrials = 3;  // trials in a row pushing past a bound before the staircase gives up

}  // namespace

std::string_view change_direction_name(ChangeDirection d) {
  switch (d) {
    case ChangeDirection::kIncrease: return "increase";
    case ChangeDirection::kDecrease: return "decrease";
    case ChangeDirection::kEither: break;
  }
  return "either";
}

bool is_changed(const StaircaseSpec& spec, double baseline, double value) {
  const double relative = (value - baseline) / baseline;
  switch (spec.direction) {
    case ChangeDirection::kIncrease: return relative >= spec.change;
    case ChangeDirection::kDecrease: return relative <= -spec.change;
    case ChangeDirection::kEither: break;
  }
  return std::abs(relative) >= spec.change;
}

StaircaseState replay_staircase(const StaircaseSpec& spec, double baseline,
                                std::span<const std::pair<double, double>> trials) {
  StaircaseState s;
  s.next_strength = spec.start;
  s.step = spec.step;
  int changed_in_a_row = 0;
  int last_direction = 0;  // -1 down, +1 up
  int at_max_unchanged = 0, at_min_changed = 0;
  for (const auto& [strength, value] : trials) {
    if (s.finished) break;
    StaircaseTrial t{strength, value, is_changed(spec, baseline, value)};
    s.trials.push_back(t);
    int direction = 0;
    if (t.changed) {
      if (++changed_in_a_row >= spec.down) {
        direction = -1;
        changed_in_a_row = 0;
      }
    } else {
      changed_in_a_row = 0;
      direction = +1;
    }
    at_max_unchanged = !t.changed && strength >= spec.max ? at_max_unchanged + 1 : 0;
    at_min_changed = t.changed && strength <= spec.min ? at_min_changed + 1 : 0;
    if (direction != 0) {
      if (last_direction != 0 && direction != last_direction) {
        s.reversal_strengths.push_back(strength);
        if (s.reversal_strengths.size() <= 2) s.step /= 2.0;
      }
      last_direction = direction;
      s.next_strength = tidy(std::clamp(strength + direction * s.step, spec.min, spec.max));
    } else {
      s.next_strength = strength;
    }
    const auto n = static_cast<int>(s.trials.size());
    if (static_cast<int>(s.reversal_strengths.size()) >= spec.reversals) {
      s.finished = true;
      s.stop_reason = std::to_string(spec.reversals) + " reversals";
    } else if (at_max_unchanged >= kBoundTrials) {
      s.finished = true;
      s.stop_reason = "no change in " + std::to_string(kBoundTrials) + " trials in a row at max: the threshold lies above it";
      return s;
    } else if (at_min_changed >= kBoundTrials) {
      s.finished = true;
      s.stop_reason = "a change in " + std::to_string(kBoundTrials) + " trials in a row at min: the threshold lies below it";
      return s;
    } else if (n >= spec.max_trials) {
      s.finished = true;
      s.stop_reason = std::to_string(spec.max_trials) + " trials (max_trials) with " +
                      std::to_string(s.reversal_strengths.size()) + " reversals";
    }
  }
  if (s.reversal_strengths.size() >= 4) {
    const double sum = std::accumulate(s.reversal_strengths.begin() + 2, s.reversal_strengths.end(), 0.0);
    s.threshold = sum / static_cast<double>(s.reversal_strengths.size() - 2);
  }
  return s;
}

}  // namespace hapticlab::protocols
