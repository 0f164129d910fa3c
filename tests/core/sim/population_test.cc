// The population simulated participants are drawn from (core/sim/
// population.h): the fitted traits' draws stay in their ranges and follow
// their parameters quantile for quantile, their densities are proper
// densities (what importance weighting between populations needs), the
// normal quantile is accurate, and bad parameters are named.
#include "core/sim/population.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/sim/participant.h"

namespace hapticlab {
namespace {

TEST(PopulationTest, TheNormalQuantileInvertsTheCdfToTwelveDigits) {
  // Published values: the 97.5th percentile 1.959963984540054, the 99.9th
  // 3.090232306167813, the 1e-10th -6.361340902404056.
  EXPECT_NEAR(standard_normal_quantile(0.975), 1.959963984540054, 1e-12);
  EXPECT_NEAR(standard_normal_quantile(0.999), 3.090232306167813, 1e-11);
  EXPECT_NEAR(standard_normal_quantile(1e-10), -6.361340902404056, 1e-9);
  for (double p = 0.001; p < 1.0; p += 0.0137) EXPECT_NEAR(standard_normal_cdf(standard_normal_quantile(p)), p, 1e-13) << p;
}

TEST(PopulationTest, DensitiesIntegrateToOneOverTheirTruncationRange) {
  // Importance weights between populations are ratios of these densities;
  // a density that misses its truncated mass would bias every weight.
  for (const double mean : {0.3, 0.65, 0.95}) {
    PopulationParams p;
    p.visual_gain_mean = mean;
    double integral = 0.0;
    constexpr int kSteps = 20000;
    const double h = (kVisualGainRange.second - kVisualGainRange.first) / kSteps;
    for (int k = 0; k < kSteps; ++k)
      integral += h * std::exp(log_density_visual_gain(kVisualGainRange.first + (k + 0.5) * h, p));
    EXPECT_NEAR(integral, 1.0, 1e-6) << "gain mean " << mean;
  }
  for (const double median : {0.04, 0.14, 0.4}) {
    PopulationParams p;
    p.consistency_median = median;
    // Integrate in log(c): density(c) dc = density(c) c dlog(c).
    const double lo = std::log(kConsistencyRange.first), hi = std::log(kConsistencyRange.second);
    constexpr int kSteps = 20000;
    const double h = (hi - lo) / kSteps;
    double integral = 0.0;
    for (int k = 0; k < kSteps; ++k) {
      const double c = std::exp(lo + (k + 0.5) * h);
      integral += h * c * std::exp(log_density_consistency(c, p));
    }
    EXPECT_NEAR(integral, 1.0, 1e-6) << "consistency median " << median;
  }
  PopulationParams p;
  EXPECT_EQ(log_density_visual_gain(kVisualGainRange.second + 0.01, p), -INFINITY);
  EXPECT_EQ(log_density_consistency(kConsistencyRange.first / 2, p), -INFINITY);
}

TEST(PopulationTest, DrawsFollowTheirDistributionQuantileForQuantile) {
  PopulationParams p;
  p.visual_gain_mean = 0.6;
  p.visual_gain_sd = 0.1;
  p.consistency_median = 0.15;
  // The median of a truncated normal far from its bounds is its mean
  // (the consistency's upper bound is 4.6 SD away: 2e-6 of mass cut off).
  EXPECT_NEAR(draw_visual_gain(0.5, p), 0.6, 1e-9);
  EXPECT_NEAR(draw_consistency(0.5, p), 0.15, 1e-6);
  // The 84.1th percentile is one SD above (the bounds are > 3 SD away).
  EXPECT_NEAR(draw_visual_gain(standard_normal_cdf(1.0), p), 0.7, 1e-4);
  // The same uniform under a larger mean gives a larger gain: the same
  // person's quantile (what plan power's draws and the fit rely on).
  PopulationParams higher = p;
  higher.visual_gain_mean = 0.7;
  for (double u = 0.01; u < 1.0; u += 0.07) EXPECT_GT(draw_visual_gain(u, higher), draw_visual_gain(u, p)) << u;
  // Every draw within the truncation range, even at the extremes of u.
  for (const double u : {0.0, 1e-300, 0.5, 1.0 - 1e-16})
    for (const double mean : {0.2, 1.0}) {
      PopulationParams q = p;
      q.visual_gain_mean = mean;
      q.visual_gain_sd = 0.5;
      const double g = draw_visual_gain(u, q);
      EXPECT_GE(g, kVisualGainRange.first);
      EXPECT_LE(g, kVisualGainRange.second);
    }
  // Force level: exactly 1 for an expert without spread; the novice factor for a novice.
  PopulationParams same;
  same.force_level_log_sd = 0.0;
  EXPECT_EQ(draw_force_level(0.9, false, same), 1.0);
  EXPECT_EQ(draw_force_level(0.9, true, same), same.novice_force_factor);
}

TEST(PopulationTest, APopulationWithoutNovicesHasNoneAndOneOfNovicesOnlyThem) {
  PopulationParams none, all;
  all.novice_share = 1.0;
  for (std::uint64_t seed = 1; seed <= 200; ++seed) {
    EXPECT_FALSE(ParticipantTraits::sample(seed, none).novice);
    const ParticipantTraits novice = ParticipantTraits::sample(seed, all);
    EXPECT_TRUE(novice.novice);
    // The same person otherwise, with the novice factor on its force level
    // (the same quantile; the truncation to 0.3..3 moves the far tails'
    // quantiles by under 1 %).
    const ParticipantTraits expert = ParticipantTraits::sample(seed, none);
    EXPECT_EQ(novice.visual_force_gain, expert.visual_force_gain);
    EXPECT_NEAR(novice.force_level / expert.force_level, none.novice_force_factor, 0.01) << seed;
  }
}

TEST(PopulationTest, BadParametersAreNamedWithTheirRange) {
  PopulationParams p;
  p.visual_gain_mean = 1.5;
  try {
    p.validate();
    FAIL() << "accepted a visual gain mean of 1.5";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("visual_gain_mean is 1.5, but must be within 0.2..1.0"));
  }
  PopulationParams q;
  q.novice_share = -0.1;
  EXPECT_THROW(q.validate(), std::invalid_argument);
  PopulationParams r;
  EXPECT_TRUE(r.set_field("consistency_median", 0.1));
  EXPECT_EQ(r.consistency_median, 0.1);
  EXPECT_FALSE(r.set_field("no_such_field", 0.1));
}

}  // namespace
}  // namespace hapticlab
