#pragma once
// The thesis' performance measures of one trial (section 3.3.5), as pure
// functions over the logged samples and task events of that trial. Exact
// definitions, with the choices the thesis leaves open: docs/analysis.md.
//
//   task window   [start_s, end_s]: start_s is the first time either tool's
//                 insertion rises through 20 mm (event insertion_passed_20mm),
//                 end_s the last moment either tip touches tissue at or after
//                 start_s (its last contact_end, or the trial's last sample
//                 when a contact lasts until the trial ends).
//   completion    end_s − start_s, one value per trial (both hands share it).
//   force         |F| = sqrt(Fx² + Fy² + Fz²) of the VE's tissue force on the
//                 tip (eq. 3.1), per sample in the window; samples with
//                 |F| < 1 mN are left out (tool not touching tissue); the
//                 median and the 95th percentile of the rest.
//   speed         |v| = sqrt(vx² + vy² + vz²) of the logged tip velocity
//                 (eq. 3.2), median over the samples in the window.
//   path length   Σ ‖p_i − p_{i−1}‖ over consecutive samples in the window.
//
// Every sample counts once, whatever its dt: the thesis took percentiles over
// its logged samples, and the haptic loop logs at a steady rate.
#include <array>
#include <cmath>
#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "analysis/stats/percentile.h"
#include "core/loop/task_event.h"

namespace hapticlab::analysis {

using Vec3d = std::array<double, 3>;

// The thesis' contact threshold: |F| below this is "not touching" (3.3.5.2).
inline constexpr double kMinContactForce_N = 1e-3;

struct TaskWindow {
  double start_s = 0.0;  // loop clock [s]
  double end_s = 0.0;    // >= start_s
  double duration_s() const { return end_s - start_s; }
};

struct TaskWindowResult {
  std::optional<TaskWindow> window;
  std::string problem;  // why there is no window (empty when there is one)
};

// events: one trial's task events, any order (sorted by time internally; a
// contact_end and contact_start at the same time are taken end-first only if
// listed so). trial_end_s: the time of the trial's last logged sample, where
// a contact still open at the end of the trial ends.
TaskWindowResult task_window(std::span<const TaskEvent> events, double trial_end_s);

// One hand's samples of a trial, in time order, as struct-of-arrays so each
// measure reads only its channel. All vectors have the same length.
struct HandSeries {
  std::vector<double> t_s;
  std::vector<Vec3d> tip_position_m;
  std::vector<Vec3d> tip_velocity_m_per_s;
  std::vector<Vec3d> ve_force_N;

  std::size_t size() const { return t_s.size(); }
  void reserve(std::size_t n);
  void clear();  // keeps the capacity, for reuse across trials
  void push_back(double t, const Vec3d& position_m, const Vec3d& velocity_m_per_s, const Vec3d& force_N);
};

// The per-sample values inside a window, in time order, before they are
// summarized (the study analysis keeps them for CDFs and the KS bootstrap).
struct WindowValues {
  std::size_t samples = 0;            // samples with start_s <= t_s <= end_s
  std::vector<double> force_N;        // |F| >= min_force_N only
  std::vector<double> speed_m_per_s;  // every sample in the window
  double path_length_m = 0.0;
};

// Throws DataError if the series' vectors differ in length, a time is not
// finite, a sample in the window has a non-finite force, velocity or
// position (naming the channel and time), or min_force_N is negative or not
// finite.
WindowValues window_values(const HandSeries& series, const TaskWindow& window,
                           double min_force_N = kMinContactForce_N);

// window_values one sample at a time, for a reader that decodes chunks
// straight into it (no whole-trial arrays): the same checks, and the same
// arithmetic in the same order, so the values are equal to the bit.
class WindowAccumulator {
 public:
  // Starts a hand: `values` is cleared (its capacity kept, for reuse) and
  // filled by add(). window.end_s may be +infinity (a contact still open
  // when the log stops: every sample from start_s on is in the window).
  // Throws DataError for a negative or non-finite min_force_N.
  void start(const TaskWindow& window, double min_force_N, WindowValues& values);
  // The hand's next sample in time order. Throws DataError as window_values.
  void add(double t_s, const Vec3d& position_m, const Vec3d& velocity_m_per_s, const Vec3d& force_N);

 private:
  TaskWindow window_;
  double min_force_N_ = kMinContactForce_N;
  WindowValues* values_ = nullptr;
  std::size_t index_ = 0;  // of the sample in the hand's series, for messages
  bool have_previous_ = false;
  Vec3d previous_m_{};
};

struct HandMetrics {
  std::size_t samples = 0;        // samples in the window
  std::size_t force_samples = 0;  // of which |F| >= the contact threshold
  // NaN when there is nothing to summarize (no contact, or no samples).
  double force_median_N = 0.0;
  double force_p95_N = 0.0;
  double speed_median_m_per_s = 0.0;
  double path_length_m = 0.0;
};

// Percentiles of the window's |F| and |v| at p = 100·i/(points − 1),
// i = 0..points−1: the quantile function behind a CDF plot.
struct HandQuantiles {
  std::vector<double> force_N;        // empty when no sample reached the contact threshold
  std::vector<double> speed_m_per_s;  // empty when the window holds no sample
};

// Summarizes the window; with quantile_points >= 2 and `quantiles` given,
// also fills the quantile grids in the same pass. Percentiles are found by
// selection, not a full sort (a thesis-sized study holds 2·10^7 samples), so
// values.force_N and values.speed_m_per_s come back reordered. A non-finite
// force or speed throws DataError (it would make every percentile
// meaningless).
HandMetrics summarize_window(WindowValues& values, PercentileMethod method = PercentileMethod::kMatlab,
                             std::size_t quantile_points = 0, HandQuantiles* quantiles = nullptr);

// window_values + summarize_window.
HandMetrics hand_metrics(const HandSeries& series, const TaskWindow& window,
                         PercentileMethod method = PercentileMethod::kMatlab,
                         double min_force_N = kMinContactForce_N);

// Euclidean norm, the |F| and |v| of eq. 3.1 and 3.2. Inline: analyze
// takes three of every update (a call each was 6 % of its time).
inline double norm3(const Vec3d& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

}  // namespace hapticlab::analysis
