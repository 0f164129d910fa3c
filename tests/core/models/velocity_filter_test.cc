#include "core/models/velocity_filter.h"

#include <cmath>
#include <complex>
#include <numbers>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

TEST(ButterworthTest, MatchesMatlabButterAt1kHz) {
  // MATLAB prints [b, a] = butter(1, 2*70/1000) as b = [0.1827 0.1827],
  // a = [1.0000 -0.6346] (4 decimals, hence the 5e-5 tolerance). By hand:
  // K = tan(pi*70/1000) = 0.2235265, b = K/(1+K) = 0.1826904,
  // a1 = (K-1)/(K+1) = -0.6346193.
  const ButterworthCoefficients c = butterworth_lowpass_1st(70.0, 1e-3);
  EXPECT_NEAR(c.b, 0.1827, 5e-5);
  EXPECT_NEAR(c.a1, -0.6346, 5e-5);
  EXPECT_NEAR(c.b, 0.1826904, 1e-7);
  EXPECT_NEAR(c.a1, -0.6346193, 1e-7);
}

TEST(ButterworthTest, UnitDcGainAndHalfPowerAtCutoffForEveryRate) {
  for (double rate_Hz : {150.0, 200.0, 500.0, 1000.0, 2000.0}) {
    const double dt = 1.0 / rate_Hz;
    const ButterworthCoefficients c = butterworth_lowpass_1st(kVelocityCutoff_Hz, dt);
    EXPECT_NEAR(2.0 * c.b / (1.0 + c.a1), 1.0, 1e-12) << rate_Hz;
    // |H(e^{jωT})| at the cut-off is 1/sqrt(2) exactly thanks to prewarping.
    const std::complex<double> z = std::polar(1.0, 2.0 * std::numbers::pi * 70.0 * dt);
    const std::complex<double> h = c.b * (1.0 + 1.0 / z) / (1.0 + c.a1 / z);
    EXPECT_NEAR(std::abs(h), 1.0 / std::sqrt(2.0), 1e-12) << rate_Hz;
    // Stable: pole inside the unit circle.
    EXPECT_LT(std::abs(c.a1), 1.0) << rate_Hz;
  }
}

TEST(VelocityFilterTest, ConstantVelocityIsRecovered) {
  VelocityFilter f;
  f.reset(0.0);
  const double dt = 1e-3, v = 0.05;
  double x = 0.0, est = 0.0;
  for (int i = 0; i < 200; ++i) {
    x += v * dt;
    est = f.update(x, dt, butterworth_lowpass_1st(70.0, dt));
  }
  EXPECT_NEAR(est, v, 1e-9);
}

TEST(VelocityFilterTest, ZeroDtHoldsTheEstimate) {
  VelocityFilter f;
  f.reset(0.0, 0.1);
  const double before = f.velocity();
  EXPECT_EQ(f.update(0.5, 0.0, ButterworthCoefficients{}), before);
}

}  // namespace
}  // namespace hapticlab
