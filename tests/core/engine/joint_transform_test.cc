// World <-> joint transforms (thesis eq. 2.16–2.21).
#include "core/engine/joint_transform.h"

#include <Eigen/LU>

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

constexpr double kMinArm = 0.02;

TEST(JointTransformTest, HandWorkedExamplesAtZeroAngles) {
  const JointVector q(0.1, 0.0, 0.0);  // 10 cm in, pointing straight down (-z)
  // Pushing the tip down (-z) with 2 N is a 2 N insertion force.
  EXPECT_TRUE(world_to_joint(q, {0, 0, -2}).isApprox(JointVector(2, 0, 0)));
  // 1 N sideways along +x at 10 cm is a 0.1 N·m yaw torque; along +y pitch.
  EXPECT_TRUE(world_to_joint(q, {1, 0, 0}).isApprox(JointVector(0, 0, 0.1)));
  EXPECT_TRUE(world_to_joint(q, {0, 1, 0}).isApprox(JointVector(0, 0.1, 0)));
  EXPECT_TRUE(tip_position(q).isApprox(Eigen::Vector3d(0, 0, -0.1)));
}

TEST(JointTransformTest, HandWorkedExampleAtThirtyDegreesPitch) {
  const double p = M_PI / 6;  // shaft direction (0, 0.5, -0.866)
  const JointVector q(0.1, p, 0.0);
  EXPECT_TRUE(insertion_direction(p, 0).isApprox(Eigen::Vector3d(0, 0.5, -std::sqrt(3) / 2)));
  // A vertical 1 N push down splits into 0.866 N along the shaft and a
  // lateral component of 0.5 N against the pitch direction: -0.05 N·m.
  const JointVector tau = world_to_joint(q, {0, 0, -1});
  EXPECT_NEAR(tau[0], std::sqrt(3) / 2, 1e-12);
  EXPECT_NEAR(tau[1], -0.05, 1e-12);
  EXPECT_NEAR(tau[2], 0.0, 1e-12);
}

TEST(JointTransformTest, AgreesWithThePrintedThesisEquationsWherePrintedConsistently) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-0.8, 0.8), ins(0.03, 0.17), f(-3, 3);
  for (int i = 0; i < 200; ++i) {
    const double L = ins(rng), p = angle(rng), y = angle(rng);
    const Eigen::Vector3d F(f(rng), f(rng), f(rng));
    // eq. 2.18 holds everywhere: L_yaw = L·cos(p), T = L_yaw·(Fx·cos y + Fz·sin y).
    const JointVector tau = world_to_joint({L, p, y}, F);
    EXPECT_NEAR(tau[2], L * std::cos(p) * (F.x() * std::cos(y) + F.z() * std::sin(y)), 1e-12);
    // At yaw = 0, eq. 2.16 (with its sin/cos typo on F_z fixed) and eq. 2.17.
    const JointVector tau0 = world_to_joint({L, p, 0.0}, F);
    EXPECT_NEAR(tau0[0], F.y() * std::sin(p) - F.z() * std::cos(p), 1e-12);
    EXPECT_NEAR(tau0[1], L * (F.y() * std::cos(p) + F.z() * std::sin(p)), 1e-12);
    // eq. 2.19 at yaw = 0.
    const JointVector t(f(rng), f(rng) * 0.1, f(rng) * 0.1);
    const Eigen::Vector3d w = joint_to_world({L, p, 0.0}, t, kMinArm);
    const double ly = L * std::cos(p);
    EXPECT_NEAR(w.x(), t[2] / ly, 1e-12);
    EXPECT_NEAR(w.y(), t[0] * std::sin(p) + t[1] / L * std::cos(p), 1e-12);
    EXPECT_NEAR(w.z(), -t[0] * std::cos(p) + t[1] / L * std::sin(p), 1e-12);
  }
}

TEST(JointTransformTest, RoundTripsInBothDirections) {
  std::mt19937_64 rng(11);
  // Pitch/yaw ±50° (Table 2.1 range); insertion from 4 cm so both moment
  // arms (L and L·cos(pitch) >= 2.6 cm) stay above the 2 cm floor.
  std::uniform_real_distribution<double> angle(-0.87, 0.87), ins(0.04, 0.17), f(-5, 5);
  for (int i = 0; i < 1000; ++i) {
    const JointVector q(ins(rng), angle(rng), angle(rng));
    const Eigen::Vector3d F(f(rng), f(rng), f(rng));
    EXPECT_LT((joint_to_world(q, world_to_joint(q, F), kMinArm) - F).norm(), 1e-12);
    const JointVector tau(f(rng), f(rng) * 0.1, f(rng) * 0.1);
    EXPECT_LT((world_to_joint(q, joint_to_world(q, tau, kMinArm)) - tau).norm(), 1e-12);
  }
}

TEST(JointTransformTest, TorquesNearTheTrocarGiveBoundedForces) {
  // At insertion 0 the moment arm is floored at kMinArm: 0.85 N·m -> 42.5 N,
  // finite, instead of a division by zero.
  const Eigen::Vector3d w = joint_to_world({0.0, 0.0, 0.0}, {0.0, 0.85, 0.0}, kMinArm);
  EXPECT_NEAR(w.norm(), 0.85 / kMinArm, 1e-9);
}

TEST(JointTransformTest, OrientationIsARotationAndMatchesEq220) {
  const double p = 0.3, y = -0.4;
  const Eigen::Matrix3d r = tool_orientation(p, y);
  EXPECT_TRUE((r * r.transpose()).isApprox(Eigen::Matrix3d::Identity(), 1e-12));
  EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
  // Entries as printed in eq. 2.20.
  EXPECT_NEAR(r(0, 0), std::cos(-y), 1e-15);
  EXPECT_NEAR(r(0, 1), std::sin(p) * std::sin(-y), 1e-15);
  EXPECT_NEAR(r(0, 2), std::cos(p) * std::sin(-y), 1e-15);
  EXPECT_NEAR(r(1, 2), -std::sin(p), 1e-15);
  EXPECT_NEAR(r(2, 0), -std::sin(-y), 1e-15);
  EXPECT_NEAR(r(2, 2), std::cos(p) * std::cos(-y), 1e-15);
}

TEST(JointTransformTest, TipOffsetIsEq220ToFirstOrder) {
  // eq. 2.20: offset = R_w·[Δyaw·L_yaw, Δpitch·L, −Δinsertion] in our frame
  // (tool z points out of the patient, hence the sign on insertion).
  const JointVector q(0.12, 0.25, -0.3);
  const JointVector delta(0.001, 0.01, -0.02);  // 1 mm, 0.01 rad, 0.02 rad
  const Eigen::Matrix3d r = tool_orientation(q[1], q[2]);
  const Eigen::Vector3d linear =
      r * Eigen::Vector3d(delta[2] * q[0] * std::cos(q[1]), delta[1] * q[0], -delta[0]);
  const Eigen::Vector3d exact = tip_offset(q, q + delta);
  // Second-order terms: about L·Δθ² = 0.12·4e-4 = 5e-5 m.
  EXPECT_LT((exact - linear).norm(), 1e-4);
  EXPECT_GT(exact.norm(), 2e-3);
  // And the orientation offset turns the measured tool into the degraded one.
  const Eigen::Matrix3d off = orientation_offset(q, q + delta);
  EXPECT_TRUE((off * r).isApprox(tool_orientation(q[1] + delta[1], q[2] + delta[2]), 1e-12));
}

}  // namespace
}  // namespace hapticlab
