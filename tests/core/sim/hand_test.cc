// One simulated hand: minimum-jerk reaching (Flash & Hogan 1985), the
// tip impedance turned into joint couplings, the cue delay line, and force
// regulation that trusts the felt force only while it agrees with what is
// seen.
//
// Noise is switched off (motor_noise_m = visual_noise = 0) so every number
// below follows from the equations in hand.h.
#include "core/sim/hand.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "core/engine/joint_transform.h"
#include "core/loop/workspace.h"

namespace hapticlab {
namespace {

constexpr double kHandDt_s = 1e-3;
constexpr int kRight = 1;

HandParams quiet() {
  HandParams p;
  p.motor_noise_m = 0.0;
  p.visual_noise = 0.0;
  return p;
}

// Minimum-jerk position fraction s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ and its peak rate
// ds/dτ at τ = 1/2: 30·(1/4)·(1/4) = 1.875.
double min_jerk(double tau) { return tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau); }
constexpr double kMinJerkPeakRate = 1.875;

struct Trace {
  std::vector<double> t_s;
  std::vector<Eigen::Vector3d> base_m;
  std::vector<HandCouplings> couplings;
};

// Steps a hand through a reach from `from` to `to` over duration_s (plus
// 0.1 s), showing the tip exactly at the aim so no visual correction starts.
Trace reach_trace(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double duration_s) {
  Hand hand;
  hand.init(kRight, quiet(), from, 42);
  hand.reach(to, 0.0, duration_s);
  Trace trace;
  const DeviceJoints q{};
  const DeviceJoints felt{};
  const int n = static_cast<int>(std::lround((duration_s + 0.1) / kHandDt_s));
  for (int k = 0; k <= n; ++k) {
    const double t = k * kHandDt_s;
    HandCouplings out;
    hand.step(t, kHandDt_s, q, felt, -0.01, to, out);
    trace.t_s.push_back(t);
    trace.base_m.push_back(hand.base());
    trace.couplings.push_back(out);
  }
  return trace;
}

TEST(CueDelayTest, ReturnsTheCueFromTheDelayAgo) {
  // Fed every 1 ms (the loop rate) with the time itself, as a running sum of
  // dt like the loop's clock, the line keeps one value per 5 ms slot (the
  // slot's latest, pushed 4 ms into it), so a delay d = 5·b ms returns a
  // value between d − 4 ms and d old: d exactly right after the 4 ms push,
  // and 4 ms less at the start of the next slot. Slots stay on the grid even
  // where the summed time falls a rounding error short of a grid point.
  CueDelay delay;
  delay.reset(-1.0);
  double min_age[2] = {1.0, 1.0}, max_age[2] = {0.0, 0.0};
  const double delays[2] = {0.040, 0.160};
  double t = 0.0;
  for (int k = 0; k <= 5000; ++k) {
    if (k > 0) t += 1e-3;
    delay.push(t, t);
    EXPECT_EQ(delay.delayed(0.0), t) << "the latest value";
    if (k < 300) continue;
    for (int j = 0; j < 2; ++j) {
      const double age = t - delay.delayed(delays[j]);
      min_age[j] = std::min(min_age[j], age);
      max_age[j] = std::max(max_age[j], age);
    }
  }
  EXPECT_NEAR(min_age[0], 0.036, 1e-9);
  EXPECT_NEAR(max_age[0], 0.040, 1e-9);
  EXPECT_NEAR(min_age[1], 0.156, 1e-9);
  EXPECT_NEAR(max_age[1], 0.160, 1e-9);
  // Pushed once per slot (the participant's 5 ms control), every push is a
  // slot of its own: one slot back is the previous push.
  CueDelay every_slot;
  every_slot.reset(-1.0);
  double t5 = 0.0, previous = -1.0;
  for (int k = 0; k <= 2000; ++k) {
    if (k > 0) t5 += CueDelay::kPeriod_s;
    every_slot.push(t5, static_cast<double>(k));
    ASSERT_EQ(every_slot.delayed(CueDelay::kPeriod_s), previous) << "push " << k << " at " << t5;
    previous = static_cast<double>(k);
  }
  // Before the first push lies the reset value; the 128 slots hold 0.64 s
  // at least, and beyond them the oldest slot is returned.
  CueDelay fresh;
  fresh.reset(-1.0);
  for (int k = 0; k <= 300; ++k) fresh.push(k * 1e-3, 1.0);
  EXPECT_EQ(fresh.delayed(0.100), 1.0);
  EXPECT_EQ(fresh.delayed(0.400), -1.0);
  EXPECT_EQ(fresh.delayed(100.0), -1.0);
}

TEST(HandTest, ReachFollowsTheMinimumJerkPathFromStartToTarget) {
  const Eigen::Vector3d from(0.03, 0.01, -0.09), to(0.0, -0.005, -0.112);
  const double T = 0.6;
  const Trace tr = reach_trace(from, to, T);
  constexpr double kTol_m = 1e-12;
  EXPECT_LT((tr.base_m.front() - from).norm(), kTol_m);
  for (std::size_t k = 0; k < tr.t_s.size(); ++k) {
    const double tau = std::min(tr.t_s[k] / T, 1.0);
    EXPECT_LT((tr.base_m[k] - (from + min_jerk(tau) * (to - from))).norm(), kTol_m) << tr.t_s[k];
  }
  // Half way in time is half way in space; the end is the target, held.
  EXPECT_LT((tr.base_m[300] - 0.5 * (from + to)).norm(), kTol_m);
  EXPECT_LT((tr.base_m[600] - to).norm(), kTol_m);
  EXPECT_LT((tr.base_m.back() - to).norm(), kTol_m);
}

TEST(HandTest, ReachSpeedIsBellShapedWithTheMinimumJerkPeak) {
  const Eigen::Vector3d from(0.03, 0.01, -0.09), to(0.0, -0.005, -0.112);
  const double T = 0.6;
  const double D = (to - from).norm();
  const Trace tr = reach_trace(from, to, T);
  // Speed from central differences of the base path.
  std::vector<double> speed(tr.t_s.size(), 0.0);
  for (std::size_t k = 1; k + 1 < tr.t_s.size(); ++k)
    speed[k] = (tr.base_m[k + 1] - tr.base_m[k - 1]).norm() / (2.0 * kHandDt_s);
  const double peak = kMinJerkPeakRate * D / T;
  // Central-difference error at the peak ≈ h²/6·|x'''| = h²/6·60·D/T³, ~1e-5
  // of the peak here; 1e-4 leaves room.
  const double tol = 1e-4 * peak;
  EXPECT_NEAR(speed[300], peak, tol);
  // Starts and ends at rest (ds/dτ = 30τ²(1−τ)² is ~3e-5 of the peak one
  // step in), symmetric about the middle, rising then falling.
  EXPECT_LT(speed[1], 1e-3 * peak);
  EXPECT_LT(speed[599], 1e-3 * peak);
  EXPECT_NEAR(speed[650], 0.0, 1e-15);
  for (int k = 1; k < 300; ++k) {
    EXPECT_NEAR(speed[static_cast<std::size_t>(k)], speed[static_cast<std::size_t>(600 - k)], tol) << k;
    EXPECT_GT(speed[static_cast<std::size_t>(k + 1)], speed[static_cast<std::size_t>(k)]) << k;
  }
}

TEST(HandTest, JointReferencesPutTheToolTipOnTheBasePathWithMatchingRates) {
  const Eigen::Vector3d from(0.03, 0.01, -0.09), to(-0.01, -0.008, -0.112);
  const double T = 0.5;
  const Trace tr = reach_trace(from, to, T);
  const double k_tip = quiet().stiffness_N_per_m;
  for (std::size_t k = 1; k + 1 < tr.t_s.size(); k += 25) {
    const HandCouplings& c = tr.couplings[k];
    // The joint references are the inverse kinematics of the base point.
    const JointVector q(c[kJointInsertion].reference_position, c[kJointPitch].reference_position,
                        c[kJointYaw].reference_position);
    EXPECT_LT((tip_world(kRight, q) - tr.base_m[k]).norm(), 1e-12) << tr.t_s[k];
    // Their velocities are the time derivatives of those references
    // (central differences, error ~1e-5 of the peak joint rate).
    for (int j : {kJointInsertion, kJointPitch, kJointYaw}) {
      const auto uj = static_cast<std::size_t>(j);
      const double rate = (tr.couplings[k + 1][uj].reference_position -
                           tr.couplings[k - 1][uj].reference_position) / (2.0 * kHandDt_s);
      const double scale = j == kJointInsertion ? 0.1 : 1.0;  // m/s vs rad/s at the peak
      EXPECT_NEAR(c[uj].reference_velocity, rate, 1e-4 * scale) << "joint " << j << " t " << tr.t_s[k];
    }
    // Tip stiffness k through the lever L: k on insertion, k·L² on pitch and
    // k·(L·cos pitch)² on yaw (a tip displaced by L·δθ pulls back k·L·δθ).
    const double L = q[0];
    EXPECT_DOUBLE_EQ(c[kJointInsertion].stiffness, k_tip);
    EXPECT_NEAR(c[kJointPitch].stiffness, k_tip * L * L, 1e-12);
    EXPECT_NEAR(c[kJointYaw].stiffness, k_tip * std::pow(L * std::cos(q[1]), 2), 1e-12);
  }
}

// A tool pointing straight down 110 mm, pressing along −z.
struct Press {
  Hand hand;
  const Eigen::Vector3d into = -Eigen::Vector3d::UnitZ();
  JointVector q = joints_for_tip(kRight, Eigen::Vector3d(0.05, 0.0, -0.11));
  DeviceJoints q_device{q[0], q[1], q[2], 0.0, 0.3};
  Eigen::Vector3d tip = tip_world(kRight, q);
  double t_s = 0.0;

  explicit Press(double target_N, double believed_k) {
    hand.init(kRight, quiet(), tip, 7);
    hand.press(into, target_N, believed_k);
  }
  // The hand feels `felt_N` of tissue reaction and sees `seen_depth_m`.
  void run(double seconds, double felt_N, double seen_depth_m) {
    // Handle force equal and opposite to a tissue force felt_N along −into.
    const JointVector jf = world_to_joint(q, felt_N * into);
    const DeviceJoints felt{jf[0], jf[1], jf[2], 0.0, 0.0};
    const int n = static_cast<int>(std::lround(seconds / kHandDt_s));
    for (int k = 0; k < n; ++k) {
      HandCouplings out;
      hand.step(t_s, kHandDt_s, q_device, felt, seen_depth_m, tip, out);
      t_s += kHandDt_s;
    }
  }
};

TEST(HandTest, PressStartsWhereHandAndTissueInSeriesGiveTheTargetForce) {
  // x = F·(1/k_hand + 1/k_tissue) = 0.5 N · (1/600 + 1/220) m/N.
  Press p(0.5, 220.0);
  EXPECT_NEAR(p.hand.press_offset_m(), 0.5 * (1.0 / 600.0 + 1.0 / 220.0), 1e-15);
  EXPECT_TRUE(p.hand.pressing());
}

TEST(HandTest, FeelingNothingTheHandPushesInAtTheRegulationRateUpToItsLimit) {
  // Estimate 0 (nothing felt, nothing seen): the offset grows at
  // F / (k·τ) = 0.5 / (600 · 0.15) = 5.56 mm/s, linearly, until the 20 mm cap.
  Press p(0.5, 220.0);
  const double x0 = p.hand.press_offset_m();
  p.run(1.0, 0.0, 0.0);
  EXPECT_EQ(p.hand.estimated_force_N(), 0.0);
  EXPECT_NEAR(p.hand.press_offset_m(), x0 + 1.0 * 0.5 / (600.0 * 0.15), 1e-12);
  p.run(3.0, 0.0, 0.0);
  EXPECT_EQ(p.hand.press_offset_m(), 0.020);
}

TEST(HandTest, FeltAndSeenForceAtTheTargetHoldThePressSteady) {
  // Felt 0.5 N; seen indentation d with 0.75 · 220 N/m · d = 0.5 N. The
  // felt cue is averaged over 0.3 s, so for the first second it lags the
  // seen one and the hand trusts it less; once it has caught up the cues
  // agree (ratio 1), the agreement relaxes back to 1 (time constant 0.5 s),
  // the felt cue's weight to 0.9, the estimate to the target, and the
  // offset stops. After 5 s both lags are below e^-9 of their start
  // (deficits ~1e-4): weight and estimate within 1e-3, and the offset
  // drifts less than (F − estimate)/(k·τ) ≈ 1e-3 N / 90 N/m/s ≈ 1e-5 m/s.
  const double F = 0.5, k_t = 220.0;
  Press p(F, k_t);
  const double seen = F / (0.75 * k_t);
  p.run(5.0, F, seen);
  const double x5 = p.hand.press_offset_m();
  EXPECT_NEAR(p.hand.estimated_force_N(), F, 1e-3);
  EXPECT_NEAR(p.hand.haptic_weight(), 0.9, 1e-3);
  p.run(1.0, F, seen);
  EXPECT_NEAR(p.hand.press_offset_m(), x5, 1e-5);
  EXPECT_NEAR(p.hand.estimated_force_N(), F, 1e-4);
}

TEST(HandTest, WithoutFeltForceTheHandFallsBackOnVision) {
  // Seeing 0.5 N worth of indentation but feeling nothing, the agreement
  // decays as (1 − dt/0.5 s)^n once the visual delay has passed: after 3 s
  // about e^−5.7 = 0.003, the felt cue's weight 0.9·0.003² ≈ 1e-5. The
  // estimate is then the visual one.
  const double F = 0.5, k_t = 220.0;
  Press p(F, k_t);
  const double seen = F / (0.75 * k_t);
  p.run(3.0, 0.0, seen);
  EXPECT_LT(p.hand.haptic_weight(), 1e-4);
  EXPECT_GT(p.hand.haptic_weight(), 1e-7);
  EXPECT_NEAR(p.hand.estimated_force_N(), F, 1e-4 * F);
}

// Impedance adaptation (hand.cc): the felt device force's deviation from
// its 1 s running mean has an RMS over a 1 s window; above 0.04 N the arm
// wants 1 + (RMS − 0.04 N)/(0.08 N) times its relaxed stiffness, at most 4
// (docs/simulation.md: "up to four times stiffer"), and gets there with a
// 0.3 s time constant. Fed `force_N(t)` on the insertion axis for
// duration_s at 1 kHz; the tip force is then that force along the shaft.
double stiffening_after(double duration_s, double (*force_N)(double)) {
  Hand hand;
  hand.init(kRight, quiet(), Eigen::Vector3d(0.05, 0.0, -0.1), 3);
  const DeviceJoints q{0.1, 0.0, 0.0, 0.0, 0.0};
  const int n = static_cast<int>(std::lround(duration_s / kHandDt_s));
  for (int k = 1; k <= n; ++k) {
    DeviceJoints f{};
    f[kJointInsertion] = force_N(k * kHandDt_s);
    hand.feel_device(q, f, kHandDt_s);
  }
  return hand.stiffening();
}

TEST(HandTest, AnUnpredictableForceStiffensTheArmByTheDocumentedRule) {
  // A 20 Hz ripple of amplitude 0.2 N (cogging-like): its mean is ~0 (the
  // 1 s mean passes 0.8 % of it) and its RMS 0.2/√2 = 0.1414 N, so the arm
  // settles at 1 + (0.1414 − 0.04)/0.08 = 2.268. After 10 s the transients
  // (1 s and 0.3 s) are gone; what remains is the 1 s variance window
  // passing 0.4 % of the 40 Hz ripple of the squared deviation, ±0.0004 N
  // of RMS, ±0.004 in stiffening before the 0.3 s smoothing: 0.005 covers it.
  const double ripple = stiffening_after(10.0, [](double t) { return 0.2 * std::sin(2 * std::numbers::pi * 20 * t); });
  EXPECT_NEAR(ripple, 1.0 + (0.2 / std::sqrt(2.0) - 0.04) / 0.08, 0.005);
  // 1 N of ripple wants 1 + (0.707 − 0.04)/0.08 = 9.3: capped at 4.
  const double strong = stiffening_after(10.0, [](double t) { return std::sin(2 * std::numbers::pi * 20 * t); });
  EXPECT_NEAR(strong, 4.0, 1e-9);
  // A steady 2 N (contact) is predicted once the mean has caught up: the
  // deviation decays as e^(−t/1 s), below 0.04 N after ~4 s, and the arm
  // relaxes back to 1 with its 0.3 s time constant: 1 + 3·e^(−(20 − 8)/0.3).
  const double steady = stiffening_after(20.0, [](double) { return 2.0; });
  EXPECT_NEAR(steady, 1.0, 1e-9);
}

TEST(HandTest, GripMovesLinearlyToItsTargetAngle) {
  Hand hand;
  hand.init(kRight, quiet(), Eigen::Vector3d(0.05, 0.0, -0.1), 1);
  hand.grip_to(0.0, 0.0, 0.2);  // from the open 0.3 rad
  const DeviceJoints q{};
  for (int k = 0; k <= 300; ++k) {
    const double t = k * kHandDt_s;
    HandCouplings out;
    hand.step(t, kHandDt_s, q, q, -0.01, Eigen::Vector3d(0.05, 0.0, -0.1), out);
    const double expected = t < 0.2 ? 0.3 * (1.0 - t / 0.2) : 0.0;
    EXPECT_NEAR(out[kJointGrip].reference_position, expected, 1e-12) << t;
    EXPECT_NEAR(out[kJointGrip].reference_velocity, t < 0.2 ? -0.3 / 0.2 : 0.0, 1e-12) << t;
  }
  EXPECT_TRUE(hand.grip_done(0.2));
}

}  // namespace
}  // namespace hapticlab
