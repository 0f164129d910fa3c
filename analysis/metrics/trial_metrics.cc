#include "analysis/metrics/trial_metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {

TaskWindowResult task_window(std::span<const TaskEvent> events, double trial_end_s) {
  // Stable: two events of one update keep the order the VE reported them in.
  std::vector<TaskEvent> sorted(events.begin(), events.end());
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const TaskEvent& a, const TaskEvent& b) { return a.t_s < b.t_s; });

  TaskWindowResult result;
  const auto first_insertion =
      std::find_if(sorted.begin(), sorted.end(),
                   [](const TaskEvent& e) { return e.type == TaskEventType::kInsertionPassed; });
  if (first_insertion == sorted.end()) {
    result.problem = "no tool reached 20 mm insertion (no insertion_passed_20mm event)";
    return result;
  }
  const double start_s = first_insertion->t_s;

  // Walk every contact change (those before start_s too: a contact that began
  // before the tools were in and lasted past start_s still counts).
  // Each instrument's contacts alternate, start then end (docs/ve_events.md):
  // one out of turn (an edited or damaged log, dropped events) leaves a
  // contact open to the last sample or closes one twice, and the window's
  // end -- the completion time -- would move with it, unnoticed.
  std::array<bool, 2> open{false, false};
  std::array<double, 2> opened_s{0.0, 0.0};
  std::optional<double> last_touch_s;
  for (const TaskEvent& e : sorted) {
    if (e.instrument < 0 || e.instrument > 1) continue;
    const auto i = static_cast<std::size_t>(e.instrument);
    const bool start = e.type == TaskEventType::kContactStart;
    if ((start || e.type == TaskEventType::kContactEnd) && start == open[i]) {
      char text[200];
      if (start)
        std::snprintf(text, sizeof text, "a contact_start at %.6g s while its contact from %.6g s is still open",
                      e.t_s, opened_s[i]);
      else
        std::snprintf(text, sizeof text, "a contact_end at %.6g s with no contact open", e.t_s);
      result.problem = std::string(i == 0 ? "the left" : "the right") + " instrument's contact events do not pair up: " +
                       text + " (an edited or damaged event log, or dropped events); measures and completion "
                       "time missing";
      return result;
    }
    if (start) {
      open[i] = true;
      opened_s[i] = e.t_s;
      if (e.t_s >= start_s) last_touch_s = std::max(last_touch_s.value_or(e.t_s), e.t_s);
    } else if (e.type == TaskEventType::kContactEnd) {
      open[i] = false;
      if (e.t_s >= start_s) last_touch_s = std::max(last_touch_s.value_or(e.t_s), e.t_s);
    }
  }
  // A contact still open when the log stops lasted until the last sample.
  if ((open[0] || open[1]) && trial_end_s >= start_s) {
    last_touch_s = std::max(last_touch_s.value_or(trial_end_s), trial_end_s);
  }
  if (!last_touch_s) {
    result.problem = "no tissue contact at or after the first 20 mm insertion";
    return result;
  }
  result.window = TaskWindow{start_s, *last_touch_s};
  return result;
}

void HandSeries::reserve(std::size_t n) {
  t_s.reserve(n);
  tip_position_m.reserve(n);
  tip_velocity_m_per_s.reserve(n);
  ve_force_N.reserve(n);
}

void HandSeries::clear() {
  t_s.clear();
  tip_position_m.clear();
  tip_velocity_m_per_s.clear();
  ve_force_N.clear();
}

void HandSeries::push_back(double t, const Vec3d& position_m, const Vec3d& velocity_m_per_s,
                           const Vec3d& force_N) {
  t_s.push_back(t);
  tip_position_m.push_back(position_m);
  tip_velocity_m_per_s.push_back(velocity_m_per_s);
  ve_force_N.push_back(force_N);
}

WindowValues window_values(const HandSeries& series, const TaskWindow& window, double min_force_N) {
  const std::size_t n = series.t_s.size();
  if (series.tip_position_m.size() != n || series.tip_velocity_m_per_s.size() != n ||
      series.ve_force_N.size() != n) {
    throw DataError("task window: the series' channels differ in length (t_s " + std::to_string(n) +
                    ", tip_position_m " + std::to_string(series.tip_position_m.size()) +
                    ", tip_velocity_m_per_s " + std::to_string(series.tip_velocity_m_per_s.size()) +
                    ", ve_force_N " + std::to_string(series.ve_force_N.size()) + ")");
  }
  WindowValues out;
  out.speed_m_per_s.reserve(n);
  out.force_N.reserve(n);
  WindowAccumulator acc;
  acc.start(window, min_force_N, out);
  for (std::size_t i = 0; i < n; ++i) {
    acc.add(series.t_s[i], series.tip_position_m[i], series.tip_velocity_m_per_s[i], series.ve_force_N[i]);
  }
  return out;
}

void WindowAccumulator::start(const TaskWindow& window, double min_force_N, WindowValues& values) {
  if (!(std::isfinite(min_force_N) && min_force_N >= 0.0)) {
    throw DataError("task window: min_force_N is " + std::to_string(min_force_N) +
                    ", but must be finite and >= 0");
  }
  window_ = window;
  min_force_N_ = min_force_N;
  values_ = &values;
  values.samples = 0;
  values.force_N.clear();
  values.speed_m_per_s.clear();
  values.path_length_m = 0.0;
  index_ = 0;
  have_previous_ = false;
}

void WindowAccumulator::add(double t, const Vec3d& p, const Vec3d& velocity_m_per_s, const Vec3d& force_N) {
  const std::size_t i = index_++;
  if (!std::isfinite(t)) {
    throw DataError("task window: t_s of sample " + std::to_string(i) + " is not finite");
  }
  if (t < window_.start_s || t > window_.end_s) return;
  WindowValues& out = *values_;
  ++out.samples;
  const double force = norm3(force_N);
  const double speed = norm3(velocity_m_per_s);
  // A NaN would otherwise fail the threshold test and vanish silently.
  // (|p| is finite exactly when |p|² is: no square root needed to know.)
  if (!std::isfinite(force) || !std::isfinite(speed) || !std::isfinite(p[0] * p[0] + p[1] * p[1] + p[2] * p[2])) {
    throw DataError("task window: sample " + std::to_string(i) + " at t_s = " + std::to_string(t) +
                    " has a non-finite " +
                    (!std::isfinite(force) ? "ve_force_N" : !std::isfinite(speed) ? "tip_velocity_m_per_s"
                                                                                   : "tip_position_m"));
  }
  if (force >= min_force_N_) out.force_N.push_back(force);
  out.speed_m_per_s.push_back(speed);
  if (have_previous_) {
    const Vec3d step{p[0] - previous_m_[0], p[1] - previous_m_[1], p[2] - previous_m_[2]};
    out.path_length_m += norm3(step);
  }
  previous_m_ = p;
  have_previous_ = true;
}

namespace {

void check_finite(const std::vector<double>& values, const char* what) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      throw DataError(std::string("task window: ") + what + " value " + std::to_string(i) +
                      " is not finite (" + std::to_string(values[i]) + ")");
    }
  }
}

}  // namespace

HandMetrics summarize_window(WindowValues& values, PercentileMethod method, std::size_t quantile_points,
                             HandQuantiles* quantiles) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  check_finite(values.force_N, "force");
  check_finite(values.speed_m_per_s, "speed");
  // The median, the 95th percentile, then the grid, all in one selection.
  std::vector<double> ps = {50.0, 95.0};
  const bool grid = quantiles != nullptr && quantile_points >= 2;
  if (grid) {
    for (std::size_t i = 0; i < quantile_points; ++i) {
      ps.push_back(100.0 * static_cast<double>(i) / static_cast<double>(quantile_points - 1));
    }
  }
  HandMetrics m;
  m.samples = values.samples;
  m.force_samples = values.force_N.size();
  m.force_median_N = m.force_p95_N = m.speed_median_m_per_s = kNaN;
  if (grid) {
    quantiles->force_N.clear();
    quantiles->speed_m_per_s.clear();
  }
  if (!values.force_N.empty()) {
    const std::vector<double> f = percentiles_select(values.force_N, ps, method);
    m.force_median_N = f[0];
    m.force_p95_N = f[1];
    if (grid) quantiles->force_N.assign(f.begin() + 2, f.end());
  }
  if (!values.speed_m_per_s.empty()) {
    const std::vector<double> v = percentiles_select(values.speed_m_per_s, ps, method);
    m.speed_median_m_per_s = v[0];
    if (grid) quantiles->speed_m_per_s.assign(v.begin() + 2, v.end());
  }
  m.path_length_m = values.samples == 0 ? kNaN : values.path_length_m;
  return m;
}

HandMetrics hand_metrics(const HandSeries& series, const TaskWindow& window, PercentileMethod method,
                         double min_force_N) {
  WindowValues values = window_values(series, window, min_force_N);
  return summarize_window(values, method);
}

}  // namespace hapticlab::analysis
