#include "core/loop/rate_schedule.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace hapticlab {
namespace {

using testing::AllOf;
using testing::HasSubstr;
using testing::ThrowsMessage;

TEST(RateScheduleTest, FixedRateGivesItsPeriodEveryTime) {
  RateSchedule s = RateSchedule::fixed(1000.0);
  EXPECT_TRUE(s.is_fixed());
  EXPECT_EQ(s.nominal_period_s(), 1e-3);
  for (int k = 0; k < 10; ++k) EXPECT_EQ(s.next_period_s(), 1e-3);
  EXPECT_EQ(RateSchedule::fixed(150.0).next_period_s(), 1.0 / 150.0);
  EXPECT_EQ(RateSchedule::fixed(2000.0).next_period_s(), 1.0 / 2000.0);
}

TEST(RateScheduleTest, RatesOutsideTheLoopRangeAreRefusedWithValueAndRange) {
  EXPECT_THAT([] { RateSchedule::fixed(149.5); },
              ThrowsMessage<std::invalid_argument>(
                  AllOf(HasSubstr("fixed()"), HasSubstr("149.5"), HasSubstr(">= 150"), HasSubstr("<= 2000"))));
  EXPECT_THROW(RateSchedule::fixed(2000.5), std::invalid_argument);
  EXPECT_THROW(RateSchedule::fixed(0.0), std::invalid_argument);
  EXPECT_THROW(RateSchedule::fixed(std::numeric_limits<double>::quiet_NaN()), std::invalid_argument);
  EXPECT_THROW(RateSchedule::fixed(std::numeric_limits<double>::infinity()), std::invalid_argument);
  EXPECT_THAT([] { RateSchedule::thesis_wander(1, 100.0); },
              ThrowsMessage<std::invalid_argument>(AllOf(HasSubstr("min_Hz is 100"))));
  EXPECT_THAT([] { RateSchedule::thesis_wander(1, 800.0, 400.0); },
              ThrowsMessage<std::invalid_argument>(HasSubstr("min_Hz (800 Hz) must be <= max_Hz (400 Hz)")));
  EXPECT_THROW(RateSchedule::thesis_wander(1, 200.0, 2500.0), std::invalid_argument);
}

TEST(RateScheduleTest, WanderStaysWithinItsBounds) {
  for (auto [lo, hi] : {std::pair{200.0, 2000.0}, std::pair{300.0, 600.0}}) {
    RateSchedule s = RateSchedule::thesis_wander(11, lo, hi);
    EXPECT_FALSE(s.is_fixed());
    EXPECT_NEAR(s.nominal_period_s(), 1.0 / std::sqrt(lo * hi), 1e-15);
    double shortest = 1.0, longest = 0.0;
    for (int k = 0; k < 100'000; ++k) {
      const double p = s.next_period_s();
      shortest = std::min(shortest, p);
      longest = std::max(longest, p);
    }
    EXPECT_GE(shortest, 1.0 / hi);
    EXPECT_LE(longest, 1.0 / lo);
    // ...and uses most of the range, not a sliver of it.
    EXPECT_LT(shortest, 1.0 / (0.8 * hi)) << lo << ".." << hi;
    EXPECT_GT(longest, 1.0 / (1.25 * lo)) << lo << ".." << hi;
  }
  RateSchedule pinned = RateSchedule::thesis_wander(11, 500.0, 500.0);
  for (int k = 0; k < 100; ++k) EXPECT_EQ(pinned.next_period_s(), 1.0 / 500.0);
}

TEST(RateScheduleTest, WanderIsDeterminedBySeed) {
  RateSchedule a = RateSchedule::thesis_wander(2024), b = RateSchedule::thesis_wander(2024),
               c = RateSchedule::thesis_wander(2025);
  int differ = 0;
  for (int k = 0; k < 1000; ++k) {
    const double pa = a.next_period_s();
    EXPECT_EQ(pa, b.next_period_s());
    differ += pa != c.next_period_s();
  }
  EXPECT_GT(differ, 990);
}

// ln(rate) on a uniform time grid of `grid_s`, over `duration_s` of schedule time.
std::vector<double> log_rate_on_grid(RateSchedule& s, double duration_s, double grid_s) {
  std::vector<double> out;
  double t_s = 0.0, next_grid_s = 0.0;
  while (t_s < duration_s) {
    const double p = s.next_period_s();
    // The rate 1/p holds over [t, t + p).
    while (next_grid_s < t_s + p) {
      out.push_back(-std::log(p));
      next_grid_s += grid_s;
    }
    t_s += p;
  }
  return out;
}

double autocorrelation(const std::vector<double>& x, std::size_t lag) {
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(x.size());
  double num = 0.0, den = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    den += (x[k] - mean) * (x[k] - mean);
    if (k + lag < x.size()) num += (x[k] - mean) * (x[k + lag] - mean);
  }
  return num / den;
}

TEST(RateScheduleTest, LogRateRevertsToTheGeometricMeanOverHalfASecond) {
  RateSchedule s = RateSchedule::thesis_wander(5);
  const double grid_s = 0.01;
  const std::vector<double> y = log_rate_on_grid(s, 600.0, grid_s);

  // Time average of ln(rate) at the centre, ln sqrt(200·2000) = ln 632 Hz;
  // the standard error over 600 s with τ = 0.5 s is about 0.025.
  double mean = 0.0;
  for (double v : y) mean += v;
  mean /= static_cast<double>(y.size());
  EXPECT_NEAR(mean, std::log(std::sqrt(200.0 * 2000.0)), 0.1);

  // Ornstein–Uhlenbeck: correlation e^(−lag/τ): 0.82 after 0.1 s, 0.37
  // after 0.5 s, none left after 3 s.
  EXPECT_GT(autocorrelation(y, 10), 0.7);
  EXPECT_NEAR(autocorrelation(y, 50), std::exp(-1.0), 0.12);
  EXPECT_LT(std::abs(autocorrelation(y, 300)), 0.15);

  // Time near each end of the range: the walk does reach the thesis' extremes.
  int slow = 0, fast = 0;
  for (double v : y) {
    slow += v < std::log(260.0);
    fast += v > std::log(1500.0);
  }
  EXPECT_GT(slow, static_cast<int>(y.size() / 100));
  EXPECT_GT(fast, static_cast<int>(y.size() / 100));
}

}  // namespace
}  // namespace hapticlab
