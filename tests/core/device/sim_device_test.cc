#include "core/device/sim_device.h"

#include <cmath>
#include <cstring>
#include <stdexcept>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/common/random.h"
#include "core/device/workstation_spec.h"
#include "core/common/clock.h"

namespace hapticlab {
namespace {

constexpr double kMid_m = 0.085;  // mid-stroke insertion

// A configured, active SimDevice on a virtual clock, read at a chosen rate.
struct Rig {
  explicit Rig(const SimDeviceParams& params = {}) : device(params) {
    EXPECT_EQ(device.configure({}), DeviceStatus::kOk);
  }
  void start() { EXPECT_EQ(device.activate(clock), DeviceStatus::kOk); }
  // Advances the clock by dt_s and reads.
  DeviceStatus tick(double dt_s) {
    clock.sleep_until(clock.now_s() + dt_s);
    return device.read(reading);
  }
  void command(int instrument, int joint, double force) {
    DeviceCommand c;
    c.force[instrument][joint] = force;
    EXPECT_EQ(device.write(c), DeviceStatus::kOk);
  }

  VirtualClock clock;
  SimDevice device;
  DeviceReading reading;
};

HandCouplings hold(int joint, double reference, double stiffness, double damping,
                   double mass = 0.0) {
  HandCouplings hand{};
  hand[joint] = {reference, 0.0, stiffness, damping, 0.0, mass};
  return hand;
}

// --- lifecycle

TEST(SimDeviceTest, LifecycleStatuses) {
  VirtualClock clock;
  SimDevice device;
  DeviceReading reading;
  EXPECT_EQ(device.read(reading), DeviceStatus::kNotActive);
  EXPECT_EQ(device.write({}), DeviceStatus::kNotActive);
  EXPECT_EQ(device.activate(clock), DeviceStatus::kNotConfigured);
  EXPECT_EQ(device.configure({.nominal_rate_Hz = 149.9}), DeviceStatus::kInvalidConfig);
  EXPECT_EQ(device.configure({.nominal_rate_Hz = 2000.1}), DeviceStatus::kInvalidConfig);
  EXPECT_EQ(device.configure({.nominal_rate_Hz = std::nan("")}), DeviceStatus::kInvalidConfig);
  EXPECT_EQ(device.activate(clock), DeviceStatus::kNotConfigured);
  EXPECT_EQ(device.configure({.nominal_rate_Hz = 150.0}), DeviceStatus::kOk);
  EXPECT_EQ(device.configure({.nominal_rate_Hz = 2000.0}), DeviceStatus::kOk);
  EXPECT_EQ(device.activate(clock), DeviceStatus::kOk);
  EXPECT_EQ(device.configure({}), DeviceStatus::kInvalidConfig);  // not while active
  EXPECT_EQ(device.read(reading), DeviceStatus::kOk);
  EXPECT_STREQ(device.name(), "sim");

  DeviceCommand c;
  c.force[0][kJointInsertion] = 3.0;
  EXPECT_EQ(device.write(c), DeviceStatus::kOk);
  clock.sleep_until(0.01);
  EXPECT_EQ(device.read(reading), DeviceStatus::kOk);
  EXPECT_EQ(device.motor_force(0)[kJointInsertion], 3.0);

  EXPECT_EQ(device.deactivate(), DeviceStatus::kOk);
  EXPECT_EQ(device.motor_force(0)[kJointInsertion], 0.0);
  EXPECT_EQ(device.read(reading), DeviceStatus::kNotActive);
  EXPECT_EQ(device.write(c), DeviceStatus::kNotActive);
  EXPECT_EQ(device.deactivate(), DeviceStatus::kOk);  // always safe
  // Reactivation starts without the old command.
  EXPECT_EQ(device.activate(clock), DeviceStatus::kOk);
  clock.sleep_until(0.02);
  EXPECT_EQ(device.read(reading), DeviceStatus::kOk);
  EXPECT_EQ(device.motor_force(0)[kJointInsertion], 0.0);
}

TEST(SimDeviceTest, InvalidParametersAndStartPosesAreRefusedWithTheValue) {
  SimDeviceParams p;
  p.joints[kJointPitch].mass = -1.0;
  EXPECT_THAT([&] { SimDevice d(p); },
              testing::ThrowsMessage<std::invalid_argument>(testing::HasSubstr("joints[1].mass is -1")));
  p = {};
  p.max_substep_s = 0.01;
  EXPECT_THROW(SimDevice{p}, std::invalid_argument);

  SimDevice device;
  EXPECT_THAT([&] { device.set_position(0, {0.2, 0, 0, 0, 0}); },
              testing::ThrowsMessage<std::invalid_argument>(testing::HasSubstr("joint 0 is 0.2")));
  EXPECT_THROW(device.set_position(2, {}), std::invalid_argument);
  EXPECT_THROW(device.set_position(0, {std::nan(""), 0, 0, 0, 0}), std::invalid_argument);
  EXPECT_THROW(device.inject_fault(DeviceStatus::kEndOfData, 0.0), std::invalid_argument);

  VirtualClock clock;
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  EXPECT_THROW(device.set_position(0, {kMid_m, 0, 0, 0, 0}), std::logic_error);
  EXPECT_TRUE(std::isnan(device.true_position(-1)[0]));
  EXPECT_TRUE(std::isnan(device.motor_force(2)[0]));
}

// --- physics

TEST(SimDeviceTest, FreeJointAcceleratesAtNetForceOverMass) {
  Rig rig;
  rig.device.set_position(0, {kMid_m, 0, 0, 0, 0});
  rig.start();
  const SimJointParams& ins = rig.device.params().joints[kJointInsertion];
  const SimJointParams& pitch = rig.device.params().joints[kJointPitch];
  const double force_N = 1.0, torque_Nm = 0.1;
  DeviceCommand c;
  c.force[0][kJointInsertion] = force_N;
  c.force[0][kJointPitch] = torque_Nm;
  ASSERT_EQ(rig.device.write(c), DeviceStatus::kOk);

  const double t_s = 0.02;
  for (int k = 0; k < 20; ++k) ASSERT_EQ(rig.tick(1e-3), DeviceStatus::kOk);

  // Sliding Coulomb friction opposes the motion: a = (F − F_c)/m. Backward
  // Euler is exact in velocity; its position leads the exact one by a·h·t/2.
  const double h_s = rig.device.params().max_substep_s;
  const double a = (force_N - ins.dynamic_friction) / ins.mass;
  EXPECT_NEAR(rig.device.velocity(0)[kJointInsertion], a * t_s, 1e-9);
  EXPECT_NEAR(rig.device.true_position(0)[kJointInsertion] - kMid_m,
              0.5 * a * t_s * t_s + 0.5 * a * h_s * t_s, 1e-9);
  const double alpha = (torque_Nm - pitch.dynamic_friction) / pitch.mass;
  EXPECT_NEAR(rig.device.velocity(0)[kJointPitch], alpha * t_s, 1e-9);
  // The other joints and the other instrument stay put.
  EXPECT_EQ(rig.device.velocity(0)[kJointYaw], 0.0);
  EXPECT_EQ(rig.device.true_position(1)[kJointInsertion], 0.5 * kLswInsertionMax_m);
  EXPECT_EQ(rig.device.hand_force(0)[kJointInsertion], 0.0);  // no hand
}

TEST(SimDeviceTest, StaticFrictionHoldsAFreeJointAgainstASmallForce) {
  Rig rig;
  rig.start();
  const double breakaway_N = rig.device.params().joints[kJointInsertion].static_friction;
  rig.command(0, kJointInsertion, 0.9 * breakaway_N);
  for (int k = 0; k < 100; ++k) rig.tick(1e-3);
  EXPECT_EQ(rig.device.velocity(0)[kJointInsertion], 0.0);
  EXPECT_EQ(rig.device.true_position(0)[kJointInsertion], 0.5 * kLswInsertionMax_m);
}

TEST(SimDeviceTest, ReadRateDoesNotChangeThePhysics) {
  // 1 ms and 5 ms gaps are both whole multiples of the 0.25 ms sub-step.
  Rig fast, slow;
  for (Rig* rig : {&fast, &slow}) {
    rig->start();
    rig->command(0, kJointInsertion, 0.5);
  }
  for (int k = 0; k < 100; ++k) fast.tick(1e-3);
  for (int k = 0; k < 20; ++k) slow.tick(5e-3);
  EXPECT_NEAR(fast.device.true_position(0)[0], slow.device.true_position(0)[0], 1e-12);
  EXPECT_NEAR(fast.device.velocity(0)[0], slow.device.velocity(0)[0], 1e-9);
}

TEST(SimDeviceTest, HandSpringSettlesAtReferencePlusMotorForceOverStiffness) {
  Rig rig;
  rig.start();
  const double ref_m = 0.08, k_N_per_m = 500.0, motor_N = 2.0;
  const double ref_rad = 0.1, k_Nm_per_rad = 2.0, motor_Nm = 0.2;
  HandCouplings hand = hold(kJointInsertion, ref_m, k_N_per_m, 10.0, 0.2);
  hand[kJointPitch] = {ref_rad, 0.0, k_Nm_per_rad, 0.02, 0.0, 1e-3};
  rig.device.set_hand(0, hand);
  DeviceCommand c;
  c.force[0][kJointInsertion] = motor_N;
  c.force[0][kJointPitch] = motor_Nm;
  ASSERT_EQ(rig.device.write(c), DeviceStatus::kOk);
  for (int k = 0; k < 2000; ++k) ASSERT_EQ(rig.tick(1e-3), DeviceStatus::kOk);

  // Static equilibrium K·(x − x_ref) = F_motor, up to the friction band F_c/K;
  // the hand then pushes back with the motor force (up to friction).
  const SimDeviceParams& p = rig.device.params();
  const double fc_N = p.joints[kJointInsertion].static_friction;
  const double fc_Nm = p.joints[kJointPitch].static_friction;
  EXPECT_NEAR(rig.device.true_position(0)[kJointInsertion], ref_m + motor_N / k_N_per_m,
              fc_N / k_N_per_m + 1e-9);
  EXPECT_NEAR(rig.device.hand_force(0)[kJointInsertion], -motor_N, fc_N + 1e-9);
  EXPECT_NEAR(rig.device.velocity(0)[kJointInsertion], 0.0, 1e-6);
  EXPECT_NEAR(rig.device.true_position(0)[kJointPitch], ref_rad + motor_Nm / k_Nm_per_rad,
              fc_Nm / k_Nm_per_rad + 1e-9);
  EXPECT_NEAR(rig.device.hand_force(0)[kJointPitch], -motor_Nm, fc_Nm + 1e-9);
  // The other instrument had no hand and no force.
  EXPECT_EQ(rig.device.hand_force(1)[kJointInsertion], 0.0);
}

TEST(SimDeviceTest, HandReferenceMovesOnLinearlyBetweenUpdates) {
  Rig rig;
  rig.device.set_position(0, {0.05, 0, 0, 0, 0});
  rig.start();
  HandCouplings hand = hold(kJointInsertion, 0.05, 2000.0, 40.0, 0.1);
  hand[kJointInsertion].reference_velocity = 0.1;  // 100 mm/s
  rig.device.set_hand(0, hand);
  // One set_hand, then 0.5 s of reads: the reference ends at 0.10 m.
  for (int k = 0; k < 500; ++k) rig.tick(1e-3);
  EXPECT_NEAR(rig.device.velocity(0)[kJointInsertion], 0.1, 1e-3);
  // Steady tracking: the damper moves with the reference (B·v_ref), so only
  // the friction stretches the spring: lag = F_c/K.
  const double fc_N = rig.device.params().joints[kJointInsertion].dynamic_friction;
  EXPECT_NEAR(rig.device.true_position(0)[kJointInsertion], 0.10 - fc_N / 2000.0, 2e-5);
  EXPECT_NEAR(rig.device.hand_force(0)[kJointInsertion], fc_N, 1e-3);
}

TEST(SimDeviceTest, InvalidHandCouplingReleasesTheJoint) {
  Rig rig;
  rig.start();
  HandCouplings hand = hold(kJointInsertion, 0.02, -5.0, 0.0);
  rig.device.set_hand(0, hand);
  hand = hold(kJointPitch, std::nan(""), 1.0, 0.0);
  rig.device.set_hand(1, hand);
  rig.device.set_hand(7, hand);  // ignored
  EXPECT_EQ(rig.device.rejected_hand_updates(), 2);
  for (int k = 0; k < 10; ++k) EXPECT_EQ(rig.tick(1e-3), DeviceStatus::kOk);
  EXPECT_EQ(rig.device.true_position(0)[kJointInsertion], 0.5 * kLswInsertionMax_m);
  EXPECT_EQ(rig.device.true_position(1)[kJointPitch], 0.0);
}

TEST(SimDeviceTest, EndStopsHoldEveryJointInsideItsRange) {
  Rig rig;
  rig.start();
  DeviceCommand c;
  c.force[0] = {5.0, 0.5, -0.5, 0.0, -0.3};
  c.force[1] = {-5.0, -0.5, 0.5, 0.0, 0.3};
  ASSERT_EQ(rig.device.write(c), DeviceStatus::kOk);
  for (int k = 0; k < 500; ++k) ASSERT_EQ(rig.tick(1e-3), DeviceStatus::kOk);

  const DeviceJoints q0 = rig.device.true_position(0), q1 = rig.device.true_position(1);
  EXPECT_EQ(q0[kJointInsertion], kLswInsertionMax_m);
  EXPECT_EQ(q0[kJointPitch], kLswPitchYawHalfRange_rad);
  EXPECT_EQ(q0[kJointYaw], -kLswPitchYawHalfRange_rad);
  EXPECT_EQ(q0[kJointGrip], kLswGripMin_rad);
  EXPECT_EQ(q1[kJointInsertion], kLswInsertionMin_m);
  EXPECT_EQ(q1[kJointPitch], -kLswPitchYawHalfRange_rad);
  EXPECT_EQ(q1[kJointGrip], kLswGripMax_rad);
  EXPECT_EQ(rig.device.velocity(0)[kJointInsertion], 0.0);
  EXPECT_EQ(rig.device.velocity(1)[kJointInsertion], 0.0);
  EXPECT_NEAR(rig.reading.position[0][kJointInsertion], kLswInsertionMax_m, 1e-12);

  // Pulling back leaves the stop at once: it absorbs, it does not stick.
  c.force[0][kJointInsertion] = -5.0;
  ASSERT_EQ(rig.device.write(c), DeviceStatus::kOk);
  rig.tick(1e-3);
  EXPECT_LT(rig.device.true_position(0)[kJointInsertion], kLswInsertionMax_m);
}

TEST(SimDeviceTest, ReadingIsTheTruePositionRoundedToTheNearestSensorCount) {
  Rig rig;
  const DeviceJoints q0 = {0.0123456, 0.3, -0.2, 1.0, 0.1};
  // 0.3 and 0.7 of a count past a count boundary: round down, then up.
  DeviceJoints q1{};
  for (int j = 0; j < kNumDeviceJoints; ++j) {
    const double res = kWorkstationJoints[j].resolution;
    q1[j] = kWorkstationJoints[j].min_position + (100.0 + (j % 2 == 0 ? 0.3 : 0.7)) * res;
  }
  rig.device.set_position(0, q0);
  rig.device.set_position(1, q1);
  rig.start();
  ASSERT_EQ(rig.tick(1e-3), DeviceStatus::kOk);

  for (int j = 0; j < kNumDeviceJoints; ++j) {
    const double res = kWorkstationJoints[j].resolution;
    for (int i = 0; i < 2; ++i) {
      const double counts = rig.reading.position[i][j] / res;
      EXPECT_NEAR(counts, std::round(counts), 1e-6) << "joint " << j;
      EXPECT_LE(std::abs(rig.reading.position[i][j] - rig.device.true_position(i)[j]), 0.5 * res + 1e-15);
    }
    const double expected_counts = 100.0 + (j % 2 == 0 ? 0.0 : 1.0);
    EXPECT_NEAR((rig.reading.position[1][j] - kWorkstationJoints[j].min_position) / res,
                expected_counts, 1e-6)
        << "joint " << j;
  }
  EXPECT_EQ(rig.reading.device_time_s, 1e-3);
}

// --- motor limits

TEST(SimDeviceTest, CommandsAreClippedToThePeakOutputAndTwistIsNotActuated) {
  Rig rig;
  rig.start();
  DeviceCommand c;
  c.force[0] = {30.0, -2.0, 0.6, 0.05, 1.0};
  c.force[1] = {-19.0, 0.85, -0.1, -1.0, -0.2};
  ASSERT_EQ(rig.device.write(c), DeviceStatus::kOk);
  rig.tick(1e-3);
  EXPECT_THAT(rig.device.motor_force(0),
              testing::ElementsAre(19.0, -0.85, 0.6, 0.0, kLswGripPeakTorque_Nm));
  EXPECT_THAT(rig.device.motor_force(1), testing::ElementsAre(-19.0, 0.85, -0.1, 0.0, -0.2));
}

TEST(SimDeviceTest, SustainedPeakForceIsCutToTheContinuousLimitWhenHot) {
  Rig rig;
  rig.start();
  rig.device.set_hand(0, hold(kJointInsertion, 0.085, 1e4, 50.0, 0.2));  // holds the handle
  rig.command(0, kJointInsertion, kLswInsertionPeakForce_N);

  // RMS of a constant F after t: F·sqrt(1 − e^(−t/τ)); it passes the
  // continuous limit at t* = −τ·ln(1 − (F_c/F_p)²) ≈ 4.08 s for τ = 10 s.
  const double tau_s = rig.device.params().thermal_time_constant_s;
  const double ratio = kLswInsertionContinuousForce_N / kLswInsertionPeakForce_N;
  const double t_star_s = -tau_s * std::log(1.0 - ratio * ratio);
  double first_limited_s = -1.0;
  for (int k = 0; k < 5000 && first_limited_s < 0.0; ++k) {
    rig.tick(1e-3);
    if (rig.device.motor_force(0)[kJointInsertion] < kLswInsertionPeakForce_N) {
      first_limited_s = rig.clock.now_s();
    }
  }
  EXPECT_NEAR(first_limited_s, t_star_s, 2e-3);
  EXPECT_EQ(rig.device.motor_force(0)[kJointInsertion], kLswInsertionContinuousForce_N);
  // It stays limited while the command stays high...
  for (int k = 0; k < 1000; ++k) rig.tick(1e-3);
  EXPECT_EQ(rig.device.motor_force(0)[kJointInsertion], kLswInsertionContinuousForce_N);
  EXPECT_LE(rig.device.thermal_rms_force(0)[kJointInsertion], kLswInsertionContinuousForce_N * 1.01);
  // ...and a command below the continuous limit passes unchanged.
  rig.command(0, kJointInsertion, 5.0);
  rig.tick(1e-3);
  EXPECT_EQ(rig.device.motor_force(0)[kJointInsertion], 5.0);
}

// --- faults

TEST(SimDeviceTest, InjectedReadFailureKeepsThePhysicsRunning) {
  Rig rig;
  rig.start();
  rig.device.inject_fault(DeviceStatus::kReadFailed, 0.0105);
  rig.command(0, kJointInsertion, 1.0);
  for (int k = 0; k < 10; ++k) EXPECT_EQ(rig.tick(1e-3), DeviceStatus::kOk);
  const DeviceReading before = rig.reading;
  EXPECT_EQ(rig.tick(1e-3), DeviceStatus::kReadFailed);
  EXPECT_EQ(before.position, rig.reading.position);  // untouched
  const double x_s = rig.device.true_position(0)[kJointInsertion];
  EXPECT_EQ(rig.tick(1e-3), DeviceStatus::kReadFailed);
  EXPECT_GT(rig.device.true_position(0)[kJointInsertion], x_s);
  rig.device.inject_fault(DeviceStatus::kOk, 0.0);
  EXPECT_EQ(rig.tick(1e-3), DeviceStatus::kOk);
}

TEST(SimDeviceTest, InjectedSensorFaultsAreReportedAsNonFiniteAndOutOfRange) {
  Rig rig;
  rig.start();
  rig.device.inject_fault(DeviceStatus::kNonFiniteReading, 0.002);
  EXPECT_EQ(rig.tick(1e-3), DeviceStatus::kOk);
  EXPECT_EQ(rig.tick(1e-3), DeviceStatus::kNonFiniteReading);
  EXPECT_TRUE(std::isnan(rig.reading.position[0][kJointInsertion]));

  rig.device.inject_fault(DeviceStatus::kOutOfRange, 0.0);
  EXPECT_EQ(rig.tick(1e-3), DeviceStatus::kOutOfRange);
  EXPECT_GT(rig.reading.position[0][kJointInsertion], kLswInsertionMax_m);
}

TEST(SimDeviceTest, NonFiniteOrRefusedCommandsNeverReachTheMotors) {
  Rig rig;
  rig.start();
  rig.command(0, kJointInsertion, 2.0);
  rig.tick(1e-3);
  DeviceCommand c;
  c.force[0][kJointInsertion] = 2.0;
  c.force[1][kJointPitch] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(rig.device.write(c), DeviceStatus::kWriteFailed);
  rig.tick(1e-3);
  EXPECT_THAT(rig.device.motor_force(0), testing::Each(0.0));
  EXPECT_THAT(rig.device.motor_force(1), testing::Each(0.0));

  rig.device.inject_fault(DeviceStatus::kWriteFailed, 0.0);
  c.force[1][kJointPitch] = 0.1;
  EXPECT_EQ(rig.device.write(c), DeviceStatus::kWriteFailed);
  rig.tick(1e-3);
  EXPECT_THAT(rig.device.motor_force(0), testing::Each(0.0));
}

TEST(SimDeviceTest, StallReanchorsAtRestInsteadOfSimulatingTheGap) {
  Rig rig;
  rig.start();
  rig.command(0, kJointInsertion, 1.0);
  for (int k = 0; k < 10; ++k) rig.tick(1e-3);
  const double x_m = rig.device.true_position(0)[kJointInsertion];
  EXPECT_EQ(rig.tick(30.0), DeviceStatus::kOk);
  EXPECT_EQ(rig.reading.device_time_s, rig.clock.now_s());
  // One sub-step from rest: v = a·h, nowhere near the end stop.
  const SimJointParams& ins = rig.device.params().joints[kJointInsertion];
  EXPECT_NEAR(rig.device.velocity(0)[kJointInsertion],
              (1.0 - ins.dynamic_friction) / ins.mass * rig.device.params().max_substep_s, 1e-9);
  EXPECT_LT(rig.device.true_position(0)[kJointInsertion] - x_m, 1e-4);
}

// --- determinism

TEST(SimDeviceTest, SameInputsGiveBitIdenticalRuns) {
  auto run = [](std::uint64_t seed) {
    Rig rig;
    rig.start();
    Random rng(seed);
    std::vector<double> trace;
    for (int k = 0; k < 300; ++k) {
      HandCouplings hand{};
      for (int j = 0; j < kNumDeviceJoints; ++j) {
        const WorkstationJointSpec& spec = kWorkstationJoints[j];
        hand[j] = {rng.uniform(spec.min_position, spec.max_position), rng.normal(0.0, 0.1),
                   (j == 0 ? 300.0 : 1.0), (j == 0 ? 5.0 : 0.01), rng.normal(0.0, 0.01), 0.0};
      }
      rig.device.set_hand(k % 2, hand);
      DeviceCommand c;
      for (auto& row : c.force) {
        for (double& f : row) f = rng.normal(0.0, 0.3);
      }
      rig.device.write(c);
      rig.tick(rng.uniform(0.5e-3, 5e-3));
      for (const DeviceJoints& q : rig.reading.position) trace.insert(trace.end(), q.begin(), q.end());
      const DeviceJoints v = rig.device.velocity(1);
      trace.insert(trace.end(), v.begin(), v.end());
    }
    return trace;
  };
  const std::vector<double> a = run(7), b = run(7), c = run(8);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)), 0);
  EXPECT_NE(a, c);
}

}  // namespace
}  // namespace hapticlab
