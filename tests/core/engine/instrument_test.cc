// One instrument, 3 DOF: safety, dt policy and integration of the chains.
#include "core/engine/instrument.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/engine/status.h"
#include "core/settings/settings_json.h"
#include "testing/example_settings.h"
#include "testing/rates.h"

namespace hapticlab {
namespace {

using testing::load_example;
using testing::with_passivity;

// A smooth two-handed-surgery-like motion of one instrument.
JointVector hand(double t) {
  return {0.10 + 0.02 * std::sin(1.7 * t), 0.2 * std::sin(1.1 * t + 0.3),
          0.15 * std::sin(0.9 * t)};
}

TEST(InstrumentTest, NonFiniteInputGivesZeroForceAndRecovers) {
  Instrument inst(load_example("all_degradations"), hand(0));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  double t = 0.0;
  for (int i = 0; i < 500; ++i) {
    t += 1e-3;
    inst.step({1e-3, hand(t), {0.3, -0.2, 0.5}});
  }
  for (const InstrumentInput& bad :
       {InstrumentInput{1e-3, {nan, 0.0, 0.0}, {0, 0, 0}},
        InstrumentInput{1e-3, hand(t), {0, inf, 0}}, InstrumentInput{nan, hand(t), {0, 0, 0}}}) {
    const InstrumentOutput out = inst.step(bad);
    EXPECT_EQ(out.displayed_force_N, Eigen::Vector3d::Zero());
    EXPECT_EQ(out.joint_force, JointVector::Zero());
    EXPECT_TRUE(out.status & kFaultNonFiniteInput);
    EXPECT_TRUE(out.degraded_position.allFinite());
  }
  // Finite again: the engine re-anchors and carries on without a spike.
  for (int i = 0; i < 100; ++i) {
    t += 1e-3;
    const InstrumentOutput out = inst.step({1e-3, hand(t), {0.3, -0.2, 0.5}});
    EXPECT_FALSE(out.status & kFaultMask);
    EXPECT_TRUE(out.displayed_force_N.allFinite());
    EXPECT_LT(out.joint_force[0], 2.0);
  }
}

// refresh_forces puts a newer VE force through the force side of the
// chains: given the force step() had, it changes nothing (to rounding);
// given another, the result is what step() would have given with it, for
// every setting whose chains only add to the VE force. Two instruments
// stepped identically, one given F_a then refreshed with F_b, the other
// given F_b: same forces. Backlash + inertia keeps step()'s force.
class RefreshForcesTest : public ::testing::TestWithParam<const char*> {};

TEST_P(RefreshForcesTest, ANewerVeForceGivesWhatStepWouldHaveGiven) {
  const EngineSettings s = load_example(GetParam());
  Instrument refreshed(s, hand(0)), direct(s, hand(0));
  double t = 0.0;
  double worst_N = 0.0;
  for (int i = 0; i < 3000; ++i) {
    t += 1e-3;
    // The VE force of this update (what a tissue would push back with),
    // and an older one that differs from it.
    const Eigen::Vector3d f_new(0.4 * std::sin(3.0 * t), -0.3 + 0.2 * std::cos(2.0 * t), 0.8 * std::sin(t));
    const Eigen::Vector3d f_old = 0.7 * f_new + Eigen::Vector3d(0.05, -0.02, 0.1);
    InstrumentOutput a = refreshed.step({1e-3, hand(t), f_old});
    refreshed.refresh_forces(f_new, a);
    const InstrumentOutput b = direct.step({1e-3, hand(t), f_new});
    ASSERT_EQ(a.degraded_position, b.degraded_position);  // positions never see the VE force
    worst_N = std::max(worst_N, (a.displayed_force_N - b.displayed_force_N).norm());
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(a.joint_force[k], b.joint_force[k], 1e-12) << "update " << i;
    EXPECT_EQ(a.status & kForceLimited, b.status & kForceLimited);
  }
  EXPECT_LT(worst_N, 1e-12) << GetParam();
}

INSTANTIATE_TEST_SUITE_P(ThesisSettings, RefreshForcesTest,
                         ::testing::Values("high_fidelity", "no_force_feedback", "friction", "cogging", "inertia",
                                           "force_saturation"));

TEST(InstrumentTest, RefreshKeepsBacklashForcesAndIsOffWithLoopEmulation) {
  // Backlash with inertia: the previous VE force moved the mass; the axes
  // keep step()'s force.
  {
    Instrument inst(load_example("inertia_backlash"), hand(0));
    double t = 0.0;
    for (int i = 0; i < 500; ++i) {
      t += 1e-3;
      InstrumentOutput out = inst.step({1e-3, hand(t), {0.2, 0.1, 0.3}});
      const JointVector before = out.joint_force;
      inst.refresh_forces({-0.5, 0.4, -0.9}, out);
      EXPECT_EQ(out.joint_force, before);
    }
  }
  // Force latency emulated: the VE force's timing is the emulation's.
  {
    EngineSettings s = load_example("high_fidelity");
    s.loop.force_latency_s = 0.005;
    Instrument inst(s, hand(0));
    double t = 0.0;
    for (int i = 0; i < 100; ++i) {
      t += 1e-3;
      InstrumentOutput out = inst.step({1e-3, hand(t), {0.2, 0.1, 0.3}});
      const InstrumentOutput before = out;
      inst.refresh_forces({-0.5, 0.4, -0.9}, out);
      EXPECT_EQ(out.joint_force, before.joint_force);
      EXPECT_EQ(out.displayed_force_N, before.displayed_force_N);
    }
  }
}

TEST(InstrumentTest, RefreshWithANonFiniteVeForceZeroesTheForce) {
  Instrument inst(load_example("friction"), hand(0));
  InstrumentOutput out = inst.step({1e-3, hand(1e-3), {0.2, 0.1, 0.3}});
  inst.refresh_forces({0.0, std::numeric_limits<double>::quiet_NaN(), 0.0}, out);
  EXPECT_EQ(out.displayed_force_N, Eigen::Vector3d::Zero());
  EXPECT_EQ(out.joint_force, JointVector::Zero());
  EXPECT_TRUE(out.status & kFaultNonFiniteInput);
}

TEST(InstrumentTest, RefreshWithAnOverflowingVeForceZeroesTheForce) {
  // As in AnOverflowingIntermediateValue...: F_i = 2.4e308 N is infinite.
  // The 1 N axis saturation would clip it to a plausible 1 N command.
  EngineSettings s = load_example("high_fidelity");
  s.translation.saturation.enabled = true;
  s.translation.saturation.level = 1.0;
  const JointVector q(0.1, 0.0, std::numbers::pi / 4);
  Instrument inst(s, q);
  inst.step({1e-3, q, {0.0, 0.0, 0.0}});
  InstrumentOutput out = inst.step({1e-3, q, {0.0, 0.0, 0.0}});
  inst.refresh_forces({1.7e308, 0.0, -1.7e308}, out);
  EXPECT_EQ(out.joint_force, JointVector::Zero());
  EXPECT_EQ(out.displayed_force_N, Eigen::Vector3d::Zero());
  EXPECT_TRUE(out.status & kFaultNonFiniteState);
}

TEST(InstrumentTest, JointCommandsNeverExceedTheDeviceLimitWhateverTheParameters) {
  // Random settings at the top of every range, huge VE forces, random poses.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    EngineSettings s = load_example("max_stable");
    s.translation.cogging.amplitude = 50.0 * u(rng);
    s.translation.friction.dynamic_level = 50.0 * u(rng);
    s.rotation.cogging.amplitude = 5.0 * u(rng);
    s.translation.inertia.mass = 0.01 + 10 * u(rng);
    s.translation.inertia.stiffness = 1e5 * u(rng) + 1.0;
    s.tip_force_saturation.enabled = false;
    s.device_limits = {1.0 + 18 * u(rng), 0.1 + 0.75 * u(rng), 0.1 + 0.75 * u(rng)};
    validate_settings(s);
    Instrument inst(s, hand(0));
    double t = 0.0;
    for (int i = 0; i < 2000; ++i) {
      t += 1e-3;
      const Eigen::Vector3d ve(400 * (u(rng) - 0.5), 400 * (u(rng) - 0.5), 400 * (u(rng) - 0.5));
      const InstrumentOutput out = inst.step({1e-3, hand(3 * t), ve});
      ASSERT_LE(std::abs(out.joint_force[0]), s.device_limits.insertion_force_N);
      ASSERT_LE(std::abs(out.joint_force[1]), s.device_limits.pitch_torque_Nm);
      ASSERT_LE(std::abs(out.joint_force[2]), s.device_limits.yaw_torque_Nm);
      const Eigen::Vector3d made = joint_to_world(hand(3 * t), out.joint_force, s.min_moment_arm_m);
      ASSERT_LT((out.displayed_force_N - made).norm(), 1e-12 * (1.0 + made.norm()));
    }
  }
}

TEST(InstrumentTest, TipForceSaturationClipsTheVeForceMagnitude) {
  const EngineSettings s = load_example("force_saturation");  // 1 N
  Instrument inst(s, hand(0));
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 2.0);
  double t = 0.0;
  for (int i = 0; i < 3000; ++i) {
    t += 1e-3;
    const Eigen::Vector3d ve(g(rng), g(rng), g(rng));
    const InstrumentOutput out = inst.step({1e-3, hand(t), ve});
    ASSERT_LE(out.displayed_force_N.norm(), 1.0 + 1e-12);
    if (ve.norm() > 1.0 && i > 0) {
      // Same direction, 1 N long (nothing else is on in this setting).
      ASSERT_TRUE(out.displayed_force_N.isApprox(ve.normalized(), 1e-9));
    }
  }
}

// The shortcut for a force well inside the clip limit must never pass what
// the long way clips: with a limit of 0 (no force feedback) a force so small
// that its squared norm underflows to 0 is still displayed as 0, and so is
// one just above a tiny limit.
TEST(InstrumentTest, TipForceSaturationClipsForcesWhoseSquareUnderflows) {
  EngineSettings s = load_example("force_saturation");
  for (double limit : {0.0, 1e-200}) {
    s.tip_force_saturation.limit_N = limit;
    Instrument inst(s, hand(0));
    double t = 0.0;
    for (int i = 0; i < 50; ++i) {
      t += 1e-3;
      const InstrumentOutput out = inst.step({1e-3, hand(t), {3e-170, -2e-170, 1e-170}});
      ASSERT_LE(out.displayed_force_N.cwiseAbs().maxCoeff(), limit * (1.0 + 1e-9)) << limit;
      ASSERT_LE(out.joint_force.cwiseAbs().maxCoeff(), limit == 0.0 ? 0.0 : 1e-190) << limit;
    }
  }
}

TEST(InstrumentTest, NoForceFeedbackDisplaysNothing) {
  Instrument inst(load_example("no_force_feedback"), hand(0));
  double t = 0.0;
  for (int i = 0; i < 1000; ++i) {
    t += 1e-3;
    const InstrumentOutput out = inst.step({1e-3, hand(t), {1.5, -2.0, 3.0}});
    ASSERT_EQ(out.displayed_force_N.norm(), 0.0);
  }
}

TEST(InstrumentTest, HighFidelityPassesTheVeThroughUnchanged) {
  Instrument inst(load_example("high_fidelity"), hand(0));
  double t = 0.0;
  for (int i = 0; i < 1000; ++i) {
    t += 1e-3;
    const Eigen::Vector3d ve(0.4 * std::sin(t), -0.3, 1.2 * std::cos(3 * t));
    const InstrumentOutput out = inst.step({1e-3, hand(t), ve});
    ASSERT_LT((out.displayed_force_N - ve).norm(), 1e-12);
    ASSERT_EQ(out.degraded_position, hand(t));
  }
}

// Runs hand() at 1 kHz, with an optional stall of stall_s starting at 1 s,
// and records the displayed force magnitude between t_from and t_to.
struct Window {
  double peak_N = 0.0;
  std::uint32_t stall_status = 0;  // status of the update that ended the stall
};
Window run_with_stall(const EngineSettings& s, double stall_s, double t_from, double t_to) {
  Instrument inst(s, hand(0));
  Window w;
  double t = 0.0;
  while (t < t_to) {
    double dt = 1e-3;
    if (stall_s > 0 && t >= 1.0 && t < 1.0 + 1e-3) dt = stall_s;
    t += dt;
    const InstrumentOutput out = inst.step({dt, hand(4 * t), {0.0, 0.0, 0.5}});
    if (dt == stall_s) w.stall_status = out.status;
    if (t >= t_from) w.peak_N = std::max(w.peak_N, out.displayed_force_N.norm());
  }
  return w;
}

TEST(InstrumentTest, A50msStallIsBridgedWithoutASpike) {
  // The hand keeps moving (up to 0.14 m/s, 0.9 rad/s) during a 50 ms stall.
  // Afterwards the force must stay within what the same motion gives without
  // a stall, over the 100 ms after the stall plus 0.1 N. Without sub-stepping
  // a 50 ms dt would put the 70 Hz Butterworth above Nyquist and integrate
  // the stiff couplings over a 7x longer step than they are specified for.
  for (const char* name : {"inertia", "all_degradations", "max_stable"}) {
    const EngineSettings s = load_example(name);
    const Window stalled = run_with_stall(s, 0.050, 1.050, 1.150);
    const Window reference = run_with_stall(s, 0.0, 1.0, 1.150);
    EXPECT_TRUE(stalled.stall_status & kDtSubstepped) << name;
    EXPECT_FALSE(stalled.stall_status & kDtResynced) << name;
    EXPECT_LE(stalled.peak_N, reference.peak_N + 0.1) << name;
  }
}

TEST(InstrumentTest, ALongStallReanchorsAndInjectsNoEnergy) {
  // After a 1 s stall nothing dynamic is left: at most the VE force (0 here),
  // cogging and friction levels, on any axis.
  const EngineSettings s = load_example("max_stable");
  std::uint32_t status = 0;
  Instrument inst(s, hand(0));
  double t = 0.0;
  for (int i = 0; i < 1000; ++i) {
    t += 1e-3;
    inst.step({1e-3, hand(4 * t), {0, 0, 0}});
  }
  t += 1.0;
  const InstrumentOutput out = inst.step({1.0, hand(4 * t), {0, 0, 0}});
  status = out.status;
  EXPECT_TRUE(status & kDtResynced);
  EXPECT_LE(std::abs(out.joint_force[0]), 0.6 + 0.45 + 1e-9);
  EXPECT_LE(std::abs(out.joint_force[1]), 0.04 + 0.03 + 1e-9);
  EXPECT_LE(std::abs(out.joint_force[2]), 0.04 + 0.03 + 1e-9);
}

// Runs `inertia` at 1 kHz for 0.5 s, then the given extra updates, then
// 1 kHz again; returns the largest insertion force after the extra updates.
double peak_after(const std::vector<InstrumentInput>& extra, std::uint32_t* extra_status) {
  Instrument inst(load_example("inertia"), hand(0));
  JointVector q = hand(0);
  for (int i = 0; i < 500; ++i) inst.step({1e-3, q, {0, 0, 0}});
  for (const InstrumentInput& in : extra) {
    const InstrumentOutput out = inst.step(in);
    if (extra_status) *extra_status |= out.status;
    q = in.position;
  }
  double peak = 0.0;
  for (int i = 0; i < 200; ++i) {
    peak = std::max(peak, std::abs(inst.step({1e-3, q, {0, 0, 0}}).joint_force[0]));
  }
  return peak;
}

TEST(InstrumentTest, TooShortOrNonPositiveDtDefersTimeInsteadOfSpiking) {
  // One encoder count (8 µm, Table 2.1) arriving with dt = 1 µs, 0 or -1 ms:
  // as a velocity that would be 8 m/s for 1 µs, which through the inertia
  // coupling is a multi-newton kick. Deferred, the step is a 8 µm move over
  // the next real millisecond: the coupling answers with a few mN.
  const JointVector step = hand(0) + JointVector(8e-6, 0, 0);
  for (double dt : {1e-6, 0.0, -1e-3}) {
    std::uint32_t status = 0;
    const double peak = peak_after({{dt, step, {0, 0, 0}}}, &status);
    EXPECT_TRUE(status & kDtDeferred) << dt;
    EXPECT_LT(peak, 0.02) << dt;
  }
  // The same count arriving at a normal 1 ms for comparison: same order.
  EXPECT_LT(peak_after({{1e-3, step, {0, 0, 0}}}, nullptr), 0.02);
}

TEST(InstrumentTest, AStoppedClockZeroesTheForceAfterTwentyUpdatesAndReanchorsWhenTimeMoves) {
  // A driver whose timer froze keeps calling with dt = 0 (or going back)
  // while the hand moves 1 mm an update. Deferred, the inertia's mass does
  // not move, so its coupling stretches: measured before this rule, at only
  // 0.1 mm an update the insertion force reached the device limit (19 N)
  // within 500 updates; at 1 mm it was 7.9 N after 15.
  Instrument inst(load_example("inertia_backlash"), hand(0));
  JointVector q = hand(0);
  for (int i = 0; i < 200; ++i) inst.step({1e-3, q, {0, 0, 0}});
  for (int i = 1; i <= 40; ++i) {
    q[kInsertion] += 1e-3;
    const InstrumentOutput out = inst.step({i % 2 ? 0.0 : -1e-3, q, {0, 0, 0}});
    EXPECT_TRUE(out.status & kDtDeferred) << i;
    if (i < kMaxStalledUpdates) {
      EXPECT_FALSE(out.status & kFaultClockStopped) << i;
    } else {
      EXPECT_TRUE(out.status & kFaultClockStopped) << i;
      EXPECT_TRUE(out.status & kFaultMask) << i;
      EXPECT_EQ(out.joint_force, JointVector::Zero()) << i;
      EXPECT_EQ(out.displayed_force_N, Eigen::Vector3d::Zero()) << i;
      EXPECT_EQ(out.degraded_position, q) << i;  // the VE sees the hand
    }
  }
  // Time moves again: re-anchored at the hand, no stored stretch released.
  const InstrumentOutput first = inst.step({1e-3, q, {0, 0, 0}});
  EXPECT_TRUE(first.status & kDtResynced);
  EXPECT_FALSE(first.status & kFaultMask);
  double peak = 0.0;
  for (int i = 0; i < 200; ++i) peak = std::max(peak, std::abs(inst.step({1e-3, q, {0, 0, 0}}).joint_force[0]));
  EXPECT_LT(peak, 0.02);
}

// A fast caller's clock that stops and starts again: its dts, each below
// 1/2000 s, add up to time that moves, and the force comes back (a
// re-anchor on every stopped update dropped the time carried, so at 4 kHz
// and faster the fault never cleared).
TEST(InstrumentTest, AFastCallersClockThatStartsAgainClearsTheFault) {
  for (const double dt : {1.0 / 4000.0, 1.0 / 20000.0}) {
    Instrument inst(load_example("inertia_backlash"), hand(0));
    for (int i = 0; i < 200; ++i) inst.step({dt, hand(i * dt), {0, 0, 0}});
    for (int i = 0; i < 30; ++i) inst.step({0.0, hand(0.05), {0, 0, 0}});
    InstrumentOutput out = inst.step({0.0, hand(0.05), {0, 0, 0}});
    ASSERT_TRUE(out.status & kFaultClockStopped) << dt;
    bool resynced = false;
    for (int i = 0; i < static_cast<int>(0.02 / dt); ++i) {  // 20 ms: the coupling takes the VE force up
      out = inst.step({dt, hand(0.05 + i * dt), {0, 0, 2.0}});
      resynced = resynced || (out.status & kDtResynced);
    }
    EXPECT_TRUE(resynced) << dt;
    EXPECT_FALSE(out.status & kFaultMask) << dt;
    EXPECT_GT(out.displayed_force_N.norm(), 0.5) << dt;  // the VE's 2 N reaches the tip again
  }
}

TEST(InstrumentTest, ACallerAt32kHzDefersButNeverCountsAsAStoppedClock) {
  // 1/2000 s is 16 periods at 32 kHz: 15 or 16 deferred updates (the sum
  // of 16 may round below 1/2000 s), then one that advances the time.
  for (const double dt : {1.0 / 32000.0, 1.0 / 31000.0, 1.0 / 20000.0}) {
    Instrument inst(load_example("inertia_backlash"), hand(0));
    std::uint32_t seen = 0;
    int deferred = 0;
    for (int i = 0; i < 32000 / 10; ++i) {  // 0.1 s
      const InstrumentOutput out = inst.step({dt, hand(i * dt), {0, 0, 0}});
      seen |= out.status;
      deferred += (out.status & kDtDeferred) != 0;
    }
    EXPECT_FALSE(seen & kFaultMask) << dt;
    EXPECT_GT(deferred, 0.85 * (0.1 / dt)) << dt;  // 9 of 10 updates or more
  }
}

TEST(InstrumentTest, AHugeFiniteDtReanchorsInsteadOfOverflowing) {
  // A timestamp in seconds since 1970 minus a zero "previous" time: 1.7e9 s,
  // with the tool 5 cm elsewhere. Re-anchor, no force from stored state.
  std::uint32_t status = 0;
  const double peak = peak_after({{1.7e9, hand(0) + JointVector(0.05, 0.1, 0), {0, 0, 0}}},
                                 &status);
  EXPECT_TRUE(status & kDtResynced);
  EXPECT_LT(peak, 0.02);
}

TEST(InstrumentTest, HighFidelityIsTransparentAtAndBeyondTheMomentArmFloorAndBehindTheTrocar) {
  // Where both moment arms (insertion, insertion·cos(pitch)) reach the
  // 2 cm floor they are exact, so the VE force reaches the tip unchanged,
  // also at negative insertion (no sign flip). 0.025·cos(0.2) = 0.0245 m.
  for (double insertion : {0.025, 0.1, -0.025, -0.05}) {
    Instrument inst(load_example("high_fidelity"), JointVector(insertion, 0.2, -0.1));
    const Eigen::Vector3d ve(0.3, 1.0, -0.5);
    inst.step({1e-3, JointVector(insertion, 0.2, -0.1), ve});
    const InstrumentOutput out = inst.step({1e-3, JointVector(insertion, 0.2, -0.1), ve});
    EXPECT_LT((out.displayed_force_N - ve).norm(), 1e-12) << insertion;
  }
}

// The displayed force is what the device-limited joint commands make,
// mapped back with the same moment arms (eq. 2.19), never the VE's force
// with a correction. Pitch = yaw = 0: d_in = (0, 0, −1), e_pitch = (0, 1,
// 0), e_yaw = (1, 0, 0); high fidelity, LSW limits 19 N and 0.85 N·m.
InstrumentOutput second_update(double insertion_m, const Eigen::Vector3d& ve) {
  const JointVector q(insertion_m, 0.0, 0.0);
  Instrument inst(load_example("high_fidelity"), q);
  inst.step({1e-3, q, ve});
  return inst.step({1e-3, q, ve});
}

TEST(InstrumentTest, DisplayedForceIsWhatTheLimitedJointCommandsMake) {
  // The case: 1e6 N at insertion 0 (it displayed the VE force's
  // 1e6 N while the motors were commanded 19 N). F_i = d_in·F = 1e6 N,
  // limited to 19 N; the moment arms are 0, so no torque: (0, 0, −19) N.
  const InstrumentOutput at_trocar = second_update(0.0, {3.0, -2.0, -1e6});
  EXPECT_EQ(at_trocar.joint_force, JointVector(19.0, 0.0, 0.0));
  EXPECT_LT((at_trocar.displayed_force_N - Eigen::Vector3d(0.0, 0.0, -19.0)).norm(), 1e-12);
  EXPECT_TRUE(at_trocar.status & kForceLimited);

  // Below the floor, 1 cm: T_pitch = 0.01·(−2) = −0.02 N·m, T_yaw =
  // 0.01·cos 0·3 = 0.03 N·m, shown through the 2 cm floor: (1.5, −1, −19) N.
  const InstrumentOutput below_floor = second_update(0.01, {3.0, -2.0, -1e6});
  EXPECT_LT((below_floor.joint_force - JointVector(19.0, -0.02, 0.03)).norm(), 1e-15);
  EXPECT_LT((below_floor.displayed_force_N - Eigen::Vector3d(1.5, -1.0, -19.0)).norm(), 1e-12);

  // 10 cm: T_pitch = 0.1·5 = 0.5 N·m (within the limit), T_yaw = 0.1·20 =
  // 2 N·m limited to 0.85 N·m: (0.85/0.1, 0.5/0.1, −19) = (8.5, 5, −19) N.
  const InstrumentOutput deeper = second_update(0.1, {20.0, 5.0, -1e6});
  EXPECT_LT((deeper.joint_force - JointVector(19.0, 0.5, 0.85)).norm(), 1e-15);
  EXPECT_LT((deeper.displayed_force_N - Eigen::Vector3d(8.5, 5.0, -19.0)).norm(), 1e-12);
}

TEST(InstrumentTest, AHugeFiniteVeForceIsLimitedNotPassedOn) {
  // 1e300 N along x at 10 cm: only T_yaw = 0.1·1e300 N·m, limited to
  // 0.85 N·m, so (0.85/0.1, 0, 0) = (8.5, 0, 0) N; it used to display a
  // difference of two 1e300s.
  const InstrumentOutput out = second_update(0.1, {1e300, 0.0, 0.0});
  EXPECT_EQ(out.joint_force, JointVector(0.0, 0.0, 0.85));
  EXPECT_LT((out.displayed_force_N - Eigen::Vector3d(8.5, 0.0, 0.0)).norm(), 1e-12);
  EXPECT_EQ(out.status & kFaultMask, 0u);

  // With the 1 N tip clip the direction is kept even where |F| overflows:
  // |(1.7e308, 0, −1.7e308)| = 2.4e308 is infinite in doubles, and the
  // clip used to scale by 1/inf, showing nothing. Expected (1, 0, −1)/√2.
  const JointVector q(0.1, 0.2, -0.1);
  Instrument clipped(load_example("force_saturation"), q);
  const Eigen::Vector3d huge(1.7e308, 0.0, -1.7e308);
  clipped.step({1e-3, q, huge});
  const InstrumentOutput c = clipped.step({1e-3, q, huge});
  EXPECT_LT((c.displayed_force_N - Eigen::Vector3d(1.0, 0.0, -1.0) / std::sqrt(2.0)).norm(), 1e-12);
  EXPECT_EQ(c.status & kFaultMask, 0u);
}

TEST(InstrumentTest, AnOverflowingIntermediateValueZeroesTheForceAndSetsTheFaultBit) {
  // Yaw 45°: d_in = (sin 45°, 0, −cos 45°), so F_i = d_in·(1.7e308, 0,
  // −1.7e308) = 2.4e308 overflows to infinity, although every input is
  // finite. The device limit would have made that a full 19 N command.
  const double yaw = std::numbers::pi / 4;
  const JointVector q(0.1, 0.0, yaw);
  Instrument inst(load_example("high_fidelity"), q);
  inst.step({1e-3, q, {0.0, 0.0, 0.0}});
  const InstrumentOutput out = inst.step({1e-3, q, {1.7e308, 0.0, -1.7e308}});
  EXPECT_TRUE(out.status & kFaultNonFiniteState);
  EXPECT_EQ(out.joint_force, JointVector::Zero());
  EXPECT_EQ(out.displayed_force_N, Eigen::Vector3d::Zero());
  EXPECT_EQ(out.degraded_position, q);
  // A sane force next: no fault, and it passes through.
  const InstrumentOutput next = inst.step({1e-3, q, {0.5, 0.0, 0.0}});
  EXPECT_EQ(next.status & kFaultMask, 0u);
  EXPECT_LT((next.displayed_force_N - Eigen::Vector3d(0.5, 0.0, 0.0)).norm(), 1e-12);
}

// docs/engine.md said an internal fault was impossible with validated
// settings; the smallest allowed values of each field found two ways:
// - a subnormal pre-sliding range d_p made K_f = μ_d/d_p infinite and the
//   stuck friction force −K_f·0 NaN (fixed in the friction model);
// - a subnormal virtual mass or inertia (the range was "> 0"): the free
//   mass in the backlash gap gains F·dt/m per update, which overflows for
//   m < F·dt/1.8e308 (1e-310 kg at 100 N, 1 kHz). That is a massless body
//   accelerating without bound, not a rounding problem: the settings now
//   refuse masses below 1 g (1e-6 kg·m²), and the model, handed one
//   anyway, faults safely (zero force, bit 2).
TEST(InstrumentTest, TheSmallestAllowedPreslidingRangeNeverFaults) {
  for (bool backlash : {true, false}) {
    EngineSettings s = load_example("max_stable");  // friction on both axes
    s.translation.backlash.enabled = s.rotation.backlash.enabled = backlash;
    s.translation.friction.presliding_displacement = std::numeric_limits<double>::denorm_min();
    s.rotation.friction.presliding_displacement = std::numeric_limits<double>::denorm_min();
    validate_settings(s);
    Instrument inst(s, hand(0));
    double t = 0.0;
    for (int i = 0; i < 3000; ++i) {
      t += 1e-3;
      const InstrumentOutput out = inst.step({1e-3, hand(3 * t), {0.5 * std::sin(5 * t), -0.3, 1.2}});
      ASSERT_EQ(out.status & kFaultMask, 0u) << "backlash " << backlash << ", update " << i;
    }
  }
}

// The floor of the mass range is safe: at 1 g and 1e-6 kg·m², with
// backlash, friction and cogging on and VE forces of several hundred N
// (far beyond the device limits), no update faults.
TEST(InstrumentTest, TheSmallestAllowedMassNeverFaults) {
  EngineSettings s = load_example("max_stable");
  for (AxisSettings* axis : {&s.translation, &s.rotation}) {
    axis->inertia.enabled = axis->backlash.enabled = axis->friction.enabled = axis->cogging.enabled = true;
  }
  s.translation.inertia.mass = 1e-3;  // kg, the floor
  s.rotation.inertia.mass = 1e-6;     // kg·m², the floor
  validate_settings(s);
  s.translation.inertia.mass = 0.99e-3;
  EXPECT_THROW(validate_settings(s), SettingsError);
  s.translation.inertia.mass = 1e-3;
  Instrument inst(s, hand(0));
  double t = 0.0;
  for (int i = 0; i < 3000; ++i) {
    t += 1e-3;
    const Eigen::Vector3d ve(300 * std::sin(5 * t), -300, 400 * std::cos(3 * t));
    const InstrumentOutput out = inst.step({1e-3, hand(3 * t), ve});
    ASSERT_EQ(out.status & kFaultMask, 0u) << "update " << i;
  }
}

TEST(InstrumentTest, ASubnormalVirtualMassInTheGapOverflowsToADocumentedFault) {
  EngineSettings s = load_example("inertia_backlash");
  s.translation.inertia.mass = 1e-310;  // kg: refused by the settings, handed to the model directly
  EXPECT_THROW(validate_settings(s), SettingsError);
  const JointVector q(0.1, 0.0, 0.0);
  Instrument inst(s, q);
  // 100 N pushing deeper (d_in = (0, 0, −1)): 100·1e-3/1e-310 = 1e309 m/s.
  const Eigen::Vector3d ve(0.0, 0.0, -100.0);
  bool faulted = false;
  for (int i = 0; i < 5 && !faulted; ++i) {
    const InstrumentOutput out = inst.step({1e-3, q, ve});
    faulted = (out.status & kFaultNonFiniteState) != 0;
    if (faulted) {
      EXPECT_EQ(out.joint_force, JointVector::Zero());
    }
  }
  EXPECT_TRUE(faulted);
}

// Leaves hand(0), wanders for 7 s and comes back to rest there at 8 s.
JointVector closed_motion(double t) {
  const double envelope = t < 7.0 ? std::sin(std::numbers::pi * t / 7.0) : 0.0;
  return hand(0) + envelope * (hand(2 * t) - hand(0));
}

// Net work the instrument does on the hand along closed_motion, paired as a
// device delivers it (zero-order hold: the force of update n acts over the
// motion until update n+1). <= 0 for a passive device.
double work_on_hand_J(const EngineSettings& s, const testing::RateCase& rate) {
  Instrument inst(s, hand(0));
  testing::DtSource dts(rate);
  double t = 0.0, work_J = 0.0;
  JointVector held_force = JointVector::Zero();
  JointVector q_prev = hand(0);
  while (t < 8.0) {
    const double dt = dts.next();
    t += dt;
    const JointVector q = closed_motion(t);
    work_J += held_force.dot(q - q_prev);
    const InstrumentOutput out = inst.step({dt, q, {0, 0, 0}});
    EXPECT_FALSE(out.status & kFaultMask);
    held_force = out.joint_force;
    q_prev = q;
  }
  return work_J;
}

class InstrumentRateTest : public ::testing::TestWithParam<testing::RateCase> {};

TEST_P(InstrumentRateTest, EnergyStoringModelsInjectNoEnergy) {
  // Inertia, backlash and cogging store and return energy; without friction
  // to hide behind, the net work must still be <= 0. Slack: 0.1 mJ, the
  // kinetic energy of 0.1 kg at 45 mm/s.
  for (const char* name : {"inertia", "inertia_backlash", "cogging", "all_degradations"}) {
    EXPECT_LE(work_on_hand_J(load_example(name), GetParam()), 1e-4) << name;
  }
}

TEST_P(InstrumentRateTest, MaximumStableSetIsPassiveAndFrictionDissipates) {
  // Everything on at Table 4.1 strengths, friction included: friction alone
  // takes 0.45 N over tens of centimetres of insertion travel, so well over
  // 10 mJ must be dissipated.
  EXPECT_LT(work_on_hand_J(load_example("max_stable"), GetParam()), -0.01);
}

// The loop as the haptic loop runs it (device => engine => VE => engine =>
// device, refresh_forces), with a VE spring of `ve_stiffness_N_per_m` pulling
// the degraded tip back to where it started: the work on the hand along
// closed_motion and every update's commanded joint force.
struct DrivenRun {
  double work_J = 0.0;
  std::vector<JointVector> forces;
};
DrivenRun drive(const EngineSettings& s, const testing::RateCase& rate, double ve_stiffness_N_per_m) {
  Instrument inst(s, hand(0));
  testing::DtSource dts(rate);
  const Eigen::Vector3d anchor = tip_position(hand(0));
  DrivenRun run;
  double t = 0.0;
  JointVector held_force = JointVector::Zero();
  JointVector q_prev = hand(0);
  Eigen::Vector3d ve = Eigen::Vector3d::Zero();
  while (t < 8.0) {
    const double dt = dts.next();
    t += dt;
    const JointVector q = closed_motion(t);
    run.work_J += held_force.dot(q - q_prev);
    InstrumentOutput out = inst.step({dt, q, ve});
    ve = -ve_stiffness_N_per_m * (out.degraded_tip_m - anchor);
    inst.refresh_forces(ve, out);
    EXPECT_FALSE(out.status & kFaultMask);
    held_force = out.joint_force;
    run.forces.push_back(out.joint_force);
    q_prev = q;
  }
  return run;
}

// Nothing unstable (Table 4.1's set, friction included, and a soft 10 N/m
// VE spring): the passivity controller, at its default 1 s window, changes
// the commanded forces by less than 1 % (RMS of the difference over RMS of
// the forces; measured 0.3 %). A window shorter than the time the models
// and the VE take to store and give back energy does not (0.1 s: 10 %;
// docs/engine.md).
TEST_P(InstrumentRateTest, PassivityBarelyTouchesAStableSet) {
  const EngineSettings s = load_example("max_stable");
  const DrivenRun off = drive(s, GetParam(), 10.0);
  const DrivenRun on = drive(with_passivity(s), GetParam(), 10.0);
  ASSERT_EQ(off.forces.size(), on.forces.size());
  double diff2 = 0.0, force2 = 0.0;
  for (std::size_t k = 0; k < off.forces.size(); ++k) {
    diff2 += (on.forces[k] - off.forces[k]).squaredNorm();
    force2 += off.forces[k].squaredNorm();
  }
  EXPECT_LT(std::sqrt(diff2 / force2), 0.01);
}

// An active coupling: the VE sees the position 20 ms late (loop latency)
// and pushes back with a 2 kN/m spring, so over a closed motion it does
// positive work on the hand (k·A²·π·sin(ωτ) a cycle): a negative damping of
// about k·τ = 40 N·s/m on insertion and (k·L²)·τ ≈ 0.4 N·m·s/rad on pitch
// and yaw (L ≈ 0.1 m). With the controller on, its damping capped above
// that (200 N·s/m, 2 N·m·s/rad), the axes are passive again; at the default
// caps (20, 0.2) it takes out only part of it, which the cap is for.
TEST_P(InstrumentRateTest, PassivityControllerMakesALateStiffVePassive) {
  nlohmann::json j = settings_to_json({"late", "", load_example("high_fidelity")});
  j["loop"]["position_latency_s"] = 0.02;
  const EngineSettings late = settings_from_json(j, "late").engine;
  const double without = drive(late, GetParam(), 2000.0).work_J;
  const double capped = drive(with_passivity(late), GetParam(), 2000.0).work_J;
  const double with = drive(with_passivity(late, 200.0, 2.0), GetParam(), 2000.0).work_J;
  EXPECT_GT(without, 0.1);  // hundreds of millijoules given to the hand
  EXPECT_LT(capped, without);
  EXPECT_LE(with, 1e-4);     // the slack of EnergyStoringModelsInjectNoEnergy
}

INSTANTIATE_TEST_SUITE_P(Rates, InstrumentRateTest, ::testing::ValuesIn(testing::kRateCases),
                         [](const auto& info) { return testing::rate_name(info.param); });

}  // namespace
}  // namespace hapticlab
