// Issue 19 §1 on the simulated rig: every degradation at Table 4.1's
// maximum in stiff contact, at 150-1000 Hz, with and without the passivity
// controller. Numbers: docs/engine.md, "Stiff contact".
#include "core/sim/stiff_contact.h"

#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "testing/example_settings.h"

namespace hapticlab {
namespace {

// 2 kN/m: over three times the hand's 600 N/m and the inertia model's
// 600 N/m coupling, the stiffness of a firm rendered wall on a desktop
// device. (3 kN/m is beyond what the controller's default damping caps
// can take out at 150 Hz: docs/engine.md.)
constexpr double kStiff_N_per_m = 2000.0;
constexpr double kHalfMillimetre_m = 0.5e-3;

StiffContactConfig stiff(StiffContactKind kind, double rate_Hz, bool passivity) {
  StiffContactConfig c;
  c.settings = testing::load_example("max_stable");
  if (passivity) c.settings = testing::with_passivity(c.settings);
  c.kind = kind;
  c.stiffness_N_per_m = kStiff_N_per_m;
  c.rate_Hz = rate_Hz;
  return c;
}

class StiffContactRateTest : public ::testing::TestWithParam<double> {};

// Without the controller the loop generates energy and the tool shakes:
// measured 1.4-49 mm peak to peak and 0.07-32 J given to the hand over 3 s
// (the least at 1000 Hz on the wall).
TEST_P(StiffContactRateTest, Table41SetIsUnstableWithoutTheController) {
  for (StiffContactKind kind : {StiffContactKind::kWall, StiffContactKind::kGraspedTissue}) {
    const StiffContactResult r = run_stiff_contact(stiff(kind, GetParam(), false));
    EXPECT_FALSE(r.faulted);
    EXPECT_GT(r.oscillation_m, 1e-3) << "kind " << static_cast<int>(kind);
    EXPECT_GT(r.device_net_J, 0.05) << "kind " << static_cast<int>(kind);
  }
}

// The same runs with the controller at its defaults: the tip still within
// half a millimetre (measured 0.35-0.44 mm), and the energy given to the
// hand bounded by what the settled contact's small limit cycle gives
// (measured 7-11 mJ over 3 s; a 320 N/m tissue gives 2-3 mJ).
TEST_P(StiffContactRateTest, PassivityControllerKeepsTheTipWithinHalfAMillimetre) {
  for (StiffContactKind kind : {StiffContactKind::kWall, StiffContactKind::kGraspedTissue}) {
    const StiffContactResult r = run_stiff_contact(stiff(kind, GetParam(), true));
    EXPECT_FALSE(r.faulted);
    EXPECT_LT(r.oscillation_m, kHalfMillimetre_m) << "kind " << static_cast<int>(kind);
    EXPECT_LT(r.device_net_J, 0.02) << "kind " << static_cast<int>(kind);
  }
}

INSTANTIATE_TEST_SUITE_P(Rates, StiffContactRateTest, ::testing::Values(150.0, 300.0, 500.0, 1000.0),
                         [](const auto& info) { return std::to_string(static_cast<int>(info.param)) + "Hz"; });

// The thesis' observation (2.3.4): holding tissue, the loop went unstable
// when the rate fell to 150-300 Hz. Here the grasped tissue shakes over 30
// times more at 150 Hz than at 1000 Hz (measured 49 mm against 1.4 mm).
TEST(StiffContactTest, GraspedTissueIsWorseAtLowRates) {
  const StiffContactResult slow = run_stiff_contact(stiff(StiffContactKind::kGraspedTissue, 150.0, false));
  const StiffContactResult fast = run_stiff_contact(stiff(StiffContactKind::kGraspedTissue, 1000.0, false));
  EXPECT_GT(slow.oscillation_m, 10.0 * fast.oscillation_m);
  EXPECT_GT(slow.device_net_J, 10.0 * fast.device_net_J);
}

TEST(StiffContactTest, TheSameConfigGivesTheSameResult) {
  const StiffContactConfig c = stiff(StiffContactKind::kGraspedTissue, 300.0, true);
  const StiffContactResult a = run_stiff_contact(c);
  const StiffContactResult b = run_stiff_contact(c);
  EXPECT_EQ(a.oscillation_m, b.oscillation_m);
  EXPECT_EQ(a.device_net_J, b.device_net_J);
  EXPECT_EQ(a.peak_ve_force_N, b.peak_ve_force_N);
}

TEST(StiffContactTest, AFieldOutOfRangeIsNamed) {
  StiffContactConfig c = stiff(StiffContactKind::kWall, 100.0, false);
  try {
    run_stiff_contact(c);
    FAIL() << "100 Hz was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("rate_Hz is 100, but must be >= 150 and <= 2000"));
  }
  c.rate_Hz = 1000.0;
  c.duration_s = 1.0;
  EXPECT_THROW(run_stiff_contact(c), std::invalid_argument);
}

}  // namespace
}  // namespace hapticlab
