#include "analysis/metrics/trial_metrics.h"

#include <cmath>
#include <limits>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// Values below are exact in binary or differ from the hand-worked result by
// rounding only.
constexpr double kMetricsTolerance = 1e-12;

TaskEvent ev(double t_s, TaskEventType type, int instrument) {
  return {t_s, type, static_cast<std::int8_t>(instrument), 0};
}

// Worked by hand: the first 20 mm insertion is the right tool's at 1.0 s (the
// left one's at 1.2 s comes later); the left tool's touch at 0.5-0.8 s ended
// before that and does not count; the last touch ends at 6.25 s (right tool).
// Window [1.0, 6.25], completion time 5.25 s. The events arrive out of order.
TEST(TaskWindowTest, FirstInsertionToLastContactEnd) {
  const std::vector<TaskEvent> events = {
      ev(4.0, TaskEventType::kContactStart, 1),      ev(1.2, TaskEventType::kInsertionPassed, 0),
      ev(0.5, TaskEventType::kContactStart, 0),      ev(0.8, TaskEventType::kContactEnd, 0),
      ev(1.0, TaskEventType::kInsertionPassed, 1),   ev(2.0, TaskEventType::kContactStart, 0),
      ev(3.5, TaskEventType::kContactEnd, 0),        ev(6.25, TaskEventType::kContactEnd, 1),
      ev(7.0, TaskEventType::kInsertionWithdrawn, 1), ev(7.5, TaskEventType::kTaskComplete, -1)};
  const TaskWindowResult r = task_window(events, 9.0);
  ASSERT_TRUE(r.window.has_value()) << r.problem;
  EXPECT_DOUBLE_EQ(r.window->start_s, 1.0);
  EXPECT_DOUBLE_EQ(r.window->end_s, 6.25);
  EXPECT_DOUBLE_EQ(r.window->duration_s(), 5.25);
  EXPECT_TRUE(r.problem.empty());
}

// A contact still open when the log ends lasts until the last sample (9 s).
TEST(TaskWindowTest, ContactOpenAtTrialEndEndsAtLastSample) {
  const std::vector<TaskEvent> events = {ev(1.0, TaskEventType::kInsertionPassed, 0),
                                         ev(2.0, TaskEventType::kContactStart, 0),
                                         ev(3.0, TaskEventType::kContactEnd, 0),
                                         ev(4.0, TaskEventType::kContactStart, 1)};
  const TaskWindowResult r = task_window(events, 9.0);
  ASSERT_TRUE(r.window.has_value());
  EXPECT_DOUBLE_EQ(r.window->end_s, 9.0);
}

// A touch that began before the tools were in and ended after counts.
TEST(TaskWindowTest, ContactSpanningTheStartCounts) {
  const std::vector<TaskEvent> events = {ev(0.5, TaskEventType::kContactStart, 0),
                                         ev(1.0, TaskEventType::kInsertionPassed, 1),
                                         ev(1.5, TaskEventType::kContactEnd, 0)};
  const TaskWindowResult r = task_window(events, 3.0);
  ASSERT_TRUE(r.window.has_value());
  EXPECT_DOUBLE_EQ(r.window->start_s, 1.0);
  EXPECT_DOUBLE_EQ(r.window->end_s, 1.5);
}

TEST(TaskWindowTest, NoInsertionOrNoContactSaysWhy) {
  const std::vector<TaskEvent> no_insertion = {ev(2.0, TaskEventType::kContactStart, 0),
                                               ev(3.0, TaskEventType::kContactEnd, 0)};
  const TaskWindowResult a = task_window(no_insertion, 5.0);
  EXPECT_FALSE(a.window.has_value());
  EXPECT_THAT(a.problem, HasSubstr("insertion_passed_20mm"));

  const std::vector<TaskEvent> contact_before = {ev(0.5, TaskEventType::kContactStart, 0),
                                                 ev(0.8, TaskEventType::kContactEnd, 0),
                                                 ev(1.0, TaskEventType::kInsertionPassed, 0)};
  const TaskWindowResult b = task_window(contact_before, 5.0);
  EXPECT_FALSE(b.window.has_value());
  EXPECT_THAT(b.problem, HasSubstr("no tissue contact"));
}

// Each instrument's contacts alternate. One out of turn moved the window's
// end without a word: a contact_end moved before its start left the
// contact open to the last sample (29.574 -> 29.957 s), a stray contact_end
// after the last contact extended it. Both leave the trial without a window,
// saying which event. Two contacts of different instruments may overlap.
TEST(TaskWindowTest, ContactEventsOutOfTurnAreAProblemNotAWindow) {
  const TaskEvent insertion = ev(1.0, TaskEventType::kInsertionPassed, 0);
  const std::vector<TaskEvent> end_before_start = {insertion, ev(2.0, TaskEventType::kContactStart, 0),
                                                   ev(3.0, TaskEventType::kContactEnd, 0),
                                                   ev(3.5, TaskEventType::kContactEnd, 0),
                                                   ev(4.0, TaskEventType::kContactStart, 0)};
  const TaskWindowResult a = task_window(end_before_start, 9.0);
  EXPECT_FALSE(a.window.has_value());
  EXPECT_THAT(a.problem, HasSubstr("the left instrument's contact events do not pair up: a contact_end at 3.5 s "
                                   "with no contact open"));
  const std::vector<TaskEvent> start_twice = {insertion, ev(2.0, TaskEventType::kContactStart, 1),
                                              ev(2.5, TaskEventType::kContactStart, 1),
                                              ev(3.0, TaskEventType::kContactEnd, 1)};
  const TaskWindowResult b = task_window(start_twice, 9.0);
  EXPECT_FALSE(b.window.has_value());
  EXPECT_THAT(b.problem, HasSubstr("the right instrument's contact events do not pair up: a contact_start at 2.5 s "
                                   "while its contact from 2 s is still open"));
  const std::vector<TaskEvent> overlapping = {insertion, ev(2.0, TaskEventType::kContactStart, 0),
                                              ev(2.5, TaskEventType::kContactStart, 1),
                                              ev(3.0, TaskEventType::kContactEnd, 0),
                                              ev(3.5, TaskEventType::kContactEnd, 1)};
  const TaskWindowResult c = task_window(overlapping, 9.0);
  ASSERT_TRUE(c.window.has_value()) << c.problem;
  EXPECT_DOUBLE_EQ(c.window->end_s, 3.5);
}

// Six samples at t = 0..5 s; the window [1, 4] holds t = 1, 2, 3, 4 (ends
// included). The samples outside carry values that would show if counted.
HandSeries worked_series() {
  HandSeries s;
  s.push_back(0, {9, 9, 9}, {0, 0, 50}, {100, 0, 0});
  s.push_back(1, {0, 0, 0}, {0, 0, 1}, {0, 0, 0.0005});  // |F| = 0.5 mN: not touching
  s.push_back(2, {3, 4, 0}, {0, 3, 4}, {0.3, 0.4, 0});   // step 5, |v| 5, |F| 0.5
  s.push_back(3, {3, 4, 12}, {2, 0, 0}, {0, 0, 2});      // step 12, |v| 2, |F| 2
  s.push_back(4, {3, 4, 12}, {0, 0, -4}, {1, 2, 2});     // step 0, |v| 4, |F| 3
  s.push_back(5, {100, 0, 0}, {0, 0, 70}, {0, 70, 0});
  return s;
}

// By hand: path 5 + 12 + 0 = 17 m. |v| = {1, 5, 2, 4}: MATLAB median of
// {1, 2, 4, 5} is 3. |F| kept {0.5, 2, 3}: median 2; MATLAB 95th: position
// 3·0.95 + 0.5 = 3.35 > n, clamped to the maximum 3.
TEST(HandMetricsTest, WorkedExampleMatlab) {
  const HandMetrics m = hand_metrics(worked_series(), {1.0, 4.0});
  EXPECT_EQ(m.samples, 4u);
  EXPECT_EQ(m.force_samples, 3u);
  EXPECT_NEAR(m.path_length_m, 17.0, kMetricsTolerance);
  EXPECT_NEAR(m.speed_median_m_per_s, 3.0, kMetricsTolerance);
  EXPECT_NEAR(m.force_median_N, 2.0, kMetricsTolerance);
  EXPECT_NEAR(m.force_p95_N, 3.0, kMetricsTolerance);
}

// The accumulator, fed one sample at a time and reused for a second hand,
// gives window_values' numbers; an open end (+inf, a contact still open when
// the log stops) takes every sample from the start on: from t = 1 that adds
// t = 5 (step |(100,0,0) - (3,4,12)| = sqrt(97^2 + 16 + 144) = sqrt(9569)).
TEST(WindowAccumulatorTest, StreamsWhatWindowValuesComputesAndReusesItsBuffers) {
  const HandSeries s = worked_series();
  WindowValues values;
  WindowAccumulator acc;
  for (int round = 0; round < 2; ++round) {
    acc.start({1.0, 4.0}, kMinContactForce_N, values);
    for (std::size_t i = 0; i < s.size(); ++i) acc.add(s.t_s[i], s.tip_position_m[i], s.tip_velocity_m_per_s[i], s.ve_force_N[i]);
    EXPECT_EQ(values.samples, 4u);
    EXPECT_EQ(values.force_N, (std::vector<double>{0.5, 2.0, 3.0}));
    EXPECT_EQ(values.speed_m_per_s, (std::vector<double>{1.0, 5.0, 2.0, 4.0}));
    EXPECT_EQ(values.path_length_m, 17.0);
  }
  acc.start({1.0, std::numeric_limits<double>::infinity()}, kMinContactForce_N, values);
  for (std::size_t i = 0; i < s.size(); ++i) acc.add(s.t_s[i], s.tip_position_m[i], s.tip_velocity_m_per_s[i], s.ve_force_N[i]);
  EXPECT_EQ(values.samples, 5u);
  EXPECT_EQ(values.force_N, (std::vector<double>{0.5, 2.0, 3.0, 70.0}));
  EXPECT_NEAR(values.path_length_m, 17.0 + std::sqrt(9569.0), kMetricsTolerance);
}

// The percentile definition is the caller's: R type 7 puts the 95th of
// {0.5, 2, 3} at 1 + 2·0.95 = 2.9, i.e. 2 + 0.9·(3 − 2) = 2.9; nearest rank
// puts the median of {1, 2, 4, 5} at x(ceil(2)) = 2.
TEST(HandMetricsTest, PercentileMethodIsSelectable) {
  EXPECT_NEAR(hand_metrics(worked_series(), {1.0, 4.0}, PercentileMethod::kR7).force_p95_N, 2.9, kMetricsTolerance);
  EXPECT_NEAR(hand_metrics(worked_series(), {1.0, 4.0}, PercentileMethod::kNearestRank).speed_median_m_per_s, 2.0,
              kMetricsTolerance);
}

// The threshold is inclusive: exactly 1 mN is contact, just below is not.
TEST(HandMetricsTest, ContactThresholdIsOneMillinewtonInclusive) {
  HandSeries s;
  s.push_back(0, {0, 0, 0}, {0, 0, 0}, {0.001, 0, 0});
  s.push_back(1, {0, 0, 0}, {0, 0, 0}, {0.000999, 0, 0});
  const HandMetrics m = hand_metrics(s, {0.0, 1.0});
  EXPECT_EQ(m.force_samples, 1u);
  EXPECT_DOUBLE_EQ(m.force_median_N, 0.001);
}

TEST(HandMetricsTest, NoContactGivesMissingForces) {
  HandSeries s;
  s.push_back(0, {0, 0, 0}, {1, 0, 0}, {0, 0, 0});
  s.push_back(1, {1, 0, 0}, {1, 0, 0}, {0, 0, 0});
  const HandMetrics m = hand_metrics(s, {0.0, 1.0});
  EXPECT_TRUE(std::isnan(m.force_median_N));
  EXPECT_TRUE(std::isnan(m.force_p95_N));
  EXPECT_DOUBLE_EQ(m.path_length_m, 1.0);
  EXPECT_DOUBLE_EQ(m.speed_median_m_per_s, 1.0);
}

TEST(HandMetricsTest, EmptyWindowGivesMissingEverything) {
  const HandMetrics m = hand_metrics(worked_series(), {10.0, 11.0});
  EXPECT_EQ(m.samples, 0u);
  EXPECT_TRUE(std::isnan(m.path_length_m));
  EXPECT_TRUE(std::isnan(m.speed_median_m_per_s));
}

// window_values keeps time order (the KS bootstrap needs it).
TEST(HandMetricsTest, WindowValuesKeepTimeOrder) {
  const WindowValues v = window_values(worked_series(), {1.0, 4.0});
  EXPECT_EQ(v.speed_m_per_s, (std::vector<double>{1, 5, 2, 4}));
  EXPECT_EQ(v.force_N.size(), 3u);
  EXPECT_NEAR(v.force_N[1], 2.0, kMetricsTolerance);
}

// The CDF grid: MATLAB percentiles of |v| = {1, 2, 4, 5} at p = 0, 25, 50,
// 75, 100 -> positions 0.5, 1.5, 2.5, 3.5, 4.5 -> 1, 1.5, 3, 4.5, 5.
TEST(HandMetricsTest, QuantileGrid) {
  WindowValues v = window_values(worked_series(), {1.0, 4.0});
  HandQuantiles q;
  const HandMetrics m = summarize_window(v, PercentileMethod::kMatlab, 5, &q);
  EXPECT_NEAR(m.speed_median_m_per_s, 3.0, kMetricsTolerance);
  ASSERT_EQ(q.speed_m_per_s.size(), 5u);
  const std::vector<double> expected = {1, 1.5, 3, 4.5, 5};
  for (std::size_t i = 0; i < 5; ++i) EXPECT_NEAR(q.speed_m_per_s[i], expected[i], kMetricsTolerance) << i;
  ASSERT_EQ(q.force_N.size(), 5u);
  EXPECT_NEAR(q.force_N.front(), 0.5, kMetricsTolerance);
  EXPECT_NEAR(q.force_N.back(), 3.0, kMetricsTolerance);
}

TEST(HandMetricsTest, BadInputNamesTheProblem) {
  HandSeries s = worked_series();
  s.ve_force_N.pop_back();
  EXPECT_THAT([&] { (void)hand_metrics(s, {0, 5}); },
              ::testing::ThrowsMessage<DataError>(HasSubstr("ve_force_N 5")));
  HandSeries n = worked_series();
  n.ve_force_N[2] = {NAN, 0, 0};
  EXPECT_THAT([&] { (void)hand_metrics(n, {0, 5}); }, ::testing::ThrowsMessage<DataError>(HasSubstr("non-finite ve_force_N")));
  EXPECT_THAT([&] { (void)window_values(worked_series(), {0, 5}, -1.0); },
              ::testing::ThrowsMessage<DataError>(HasSubstr("min_force_N is -1")));
}

}  // namespace
}  // namespace hapticlab::analysis
