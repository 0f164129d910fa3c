// The clip application task (thesis 3.3.2.2): the duct wall's spring, made
// stiffer where the grasper holds it; a clip registers only with the
// applier's jaws closing on the duct at the next marker, from a still tool
// or on a held duct; three clips complete the task; the VE's occasional
// failure to register a correct clip.
//
// Tools are scripted through VeDriver and held still unless a test moves
// them, so contact forces are the springs alone. Hand-worked numbers for
// the defaults (ClipParams): duct radius 2.5 mm, wall 150 N/m, held wall
// 350 N/m, base 250 N/m, marker tolerance 2.5 mm, seat reach 1.5 mm,
// still speed 8 mm/s, markers 9 mm apart, clip kick 0.05 N·m for 0.15 s.
#include "core/sim/clip_task.h"

#include <cmath>

#include <gtest/gtest.h>

#include "ve_driver.h"

namespace hapticlab {
namespace {

using testing_sim::kGripClosed;
using testing_sim::kGripOpen;
using testing_sim::VeDriver;

constexpr double kClipForceTolerance_N = 1e-9;  // springs × ~1e-16 m of trig round trip
constexpr double kTorqueTolerance_Nm = 1e-12;

// Deterministic unless a test wants the VE's detection failures.
ClipParams reliable() {
  ClipParams p;
  p.detection_failure = 0.0;
  return p;
}

// On top of the duct above x, `depth_m` into its wall.
Eigen::Vector3d on_duct(const ClipTask& task, double x_m, double depth_m) {
  return task.axis_point(x_m) + Eigen::Vector3d(0.0, 0.0, task.params().duct_radius_m - depth_m);
}

// Holds the tools still for `steps` updates (the tip velocity estimate of a
// jump decays by 0.76 per 1 ms update: 100 updates take 9 m/s below 1e-9).
void settle(VeDriver& d, int steps = 100) {
  for (int k = 0; k < steps; ++k) d.step();
}

// Closes the right jaws (one update), then opens them again (one update).
void close_and_open(VeDriver& d) {
  d.grip[1] = kGripClosed;
  d.step();
  d.grip[1] = kGripOpen;
  d.step();
}

TEST(ClipTaskTest, ThreeMarkersNineMillimetresApartOnALayoutFromTheSeed) {
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const ClipTask task(seed);
    EXPECT_NEAR(task.marker_x_m(1) - task.marker_x_m(0), 0.009, 1e-15);
    EXPECT_NEAR(task.marker_x_m(2) - task.marker_x_m(1), 0.009, 1e-15);
    EXPECT_LE(std::abs(task.marker_x_m(1)), 0.004);
    EXPECT_LE(std::abs(task.duct_y_m()), 0.005);
    EXPECT_EQ(task.clips_applied(), 0);
    EXPECT_FALSE(task.complete());
  }
  EXPECT_NE(ClipTask(1).duct_y_m(), ClipTask(2).duct_y_m());
  EXPECT_EQ(ClipTask(3).marker_x_m(0), ClipTask(3).marker_x_m(0));
}

TEST(ClipTaskTest, DuctWallIsARadialSpringStifferWhereTheGrasperHoldsIt) {
  ClipTask task(1, reliable());
  VeDriver d(task);
  const double m0 = task.marker_x_m(0);
  // 0.5 mm into the top of the unheld duct: 150 N/m · 0.5 mm = 0.075 N up.
  d.tip[1] = on_duct(task, m0, 0.0005);
  d.step();
  EXPECT_NEAR(d.out.tip_force_N[1].z(), 0.075, kClipForceTolerance_N);
  EXPECT_NEAR(d.out.tip_force_N[1].head<2>().norm(), 0.0, kClipForceTolerance_N);
  EXPECT_TRUE(d.out.in_contact[1]);
  // From the side the normal is horizontal: 1 mm into the wall at the
  // duct's front (−y) pushes 0.15 N towards −y.
  d.tip[1] = task.axis_point(m0) + Eigen::Vector3d(0.0, -0.0015, 0.0);
  settle(d);
  EXPECT_NEAR(d.out.tip_force_N[1].y(), -0.15, kClipForceTolerance_N);
  EXPECT_NEAR(d.out.tip_force_N[1].z(), 0.0, kClipForceTolerance_N);

  // The left grasper takes the duct 8 mm left of the marker (tip on the
  // axis: no stretch, no force) ...
  d.tip[0] = task.axis_point(m0 - 0.008);
  d.grip[0] = kGripClosed;
  d.tip[1] = on_duct(task, m0, 0.0005);
  settle(d);
  ASSERT_TRUE(task.grasp().holding());
  EXPECT_EQ(d.count(TaskEventType::kGraspStart, 0), 1);
  EXPECT_NEAR(d.out.tip_force_N[0].norm(), 0.0, kClipForceTolerance_N);
  // ... and within 20 mm of it the wall is 350 N/m: 0.175 N at 0.5 mm.
  EXPECT_NEAR(d.out.tip_force_N[1].z(), 0.175, kClipForceTolerance_N);
  // Beyond 20 mm (the third marker is 26 mm away) the duct is its own
  // soft self again.
  d.tip[1] = on_duct(task, task.marker_x_m(2), 0.0005);
  settle(d);
  EXPECT_NEAR(d.out.tip_force_N[1].z(), 0.075, kClipForceTolerance_N);
  // Lifting the grasped duct 4 mm: the tissue pulls back with 150 N/m.
  d.tip[0] = task.axis_point(m0 - 0.008) + Eigen::Vector3d(0.0, 0.0, 0.004);
  settle(d);
  EXPECT_NEAR(d.out.tip_force_N[0].z(), -0.6, kClipForceTolerance_N);
}

TEST(ClipTaskTest, StructuresBelowPushBackWithTheirOwnSpring) {
  ClipTask task(2, reliable());
  VeDriver d(task);
  // Beyond the duct's ends (|x| > 35 mm), 2 mm into the base: 250 · 0.002.
  d.tip[1] = Eigen::Vector3d(0.040, 0.0, task.params().base_z_m - 0.002);
  d.step();
  EXPECT_NEAR(d.out.tip_force_N[1].z(), 0.5, kClipForceTolerance_N);
  EXPECT_TRUE(d.out.in_contact[1]);
}

TEST(ClipTaskTest, ClipClosedOnTheDuctAtTheMarkerIsAppliedAndKicksTheHandle) {
  ClipTask task(3, reliable());
  VeDriver d(task);
  d.tip[1] = on_duct(task, task.marker_x_m(0) + 0.002, 0.0005);  // 2 mm off: inside 2.5 mm
  settle(d);
  d.grip[1] = kGripClosed;
  const double t_clip = d.t_s;
  d.step();
  EXPECT_EQ(task.clips_applied(), 1);
  EXPECT_EQ(task.clips_missed(), 0);
  ASSERT_EQ(d.count(TaskEventType::kClipApplied, 1), 1);
  EXPECT_EQ(d.events.back().type, TaskEventType::kClipApplied);
  EXPECT_EQ(d.events.back().index, 0);
  EXPECT_EQ(d.events.back().t_s, t_clip);
  // The handle pushes the jaws open with 0.05 N·m for 0.15 s.
  EXPECT_NEAR(d.out.grip_torque_Nm[1], 0.05, kTorqueTolerance_Nm);
  EXPECT_EQ(d.out.grip_torque_Nm[0], 0.0);
  for (int k = 0; k < 140; ++k) d.step();  // to t_clip + 0.140 s
  EXPECT_NEAR(d.out.grip_torque_Nm[1], 0.05, kTorqueTolerance_Nm);
  for (int k = 0; k < 20; ++k) d.step();   // to t_clip + 0.160 s
  EXPECT_EQ(d.out.grip_torque_Nm[1], 0.0);
  // Jaws still closed: no second clip until they open and close again.
  EXPECT_EQ(task.clips_applied(), 1);
}

TEST(ClipTaskTest, ClipOutsideTheMarkerOrOffTheDuctIsMissed) {
  ClipTask task(4, reliable());
  VeDriver d(task);
  const double m0 = task.marker_x_m(0);
  // 3 mm beside the marker, beyond its 2.5 mm tolerance.
  d.tip[1] = on_duct(task, m0 + 0.003, 0.0005);
  settle(d);
  close_and_open(d);
  EXPECT_EQ(task.clips_applied(), 0);
  EXPECT_EQ(task.clips_missed(), 1);
  ASSERT_EQ(d.count(TaskEventType::kClipMissed, 1), 1);
  // At the marker but 3 mm above the duct (5.5 mm from its axis, beyond
  // radius + 1.5 mm seat reach).
  d.tip[1] = on_duct(task, m0, -0.003);
  settle(d);
  close_and_open(d);
  EXPECT_EQ(task.clips_missed(), 2);
  // 1 mm above it is within the seat reach: applied.
  d.tip[1] = on_duct(task, m0, -0.001);
  settle(d);
  close_and_open(d);
  EXPECT_EQ(task.clips_missed(), 2);
  EXPECT_EQ(task.clips_applied(), 1);
  // A miss carries the number of the clip that was being placed.
  for (const TaskEvent& e : d.events) {
    if (e.type == TaskEventType::kClipMissed) {
      EXPECT_EQ(e.index, 0);
    }
  }
  // Past the end of the duct (it spans |x| <= 35 mm) nothing is on it.
  d.tip[1] = on_duct(task, 0.036, 0.0005);
  settle(d);
  close_and_open(d);
  EXPECT_EQ(task.clips_missed(), 3);
}

TEST(ClipTaskTest, MovingToolNeedsTheGrasperToHoldTheDuct) {
  // Sliding along the duct at 20 mm/s, 2.5× the 8 mm/s a loose duct
  // tolerates, the applier closes 1 mm before the marker.
  for (bool held : {false, true}) {
    ClipTask task(5, reliable());
    VeDriver d(task);
    const double m0 = task.marker_x_m(0);
    if (held) {
      d.tip[0] = task.axis_point(m0 - 0.008);
      d.grip[0] = kGripClosed;
    }
    const double speed = 0.020;
    const double x0 = m0 - 0.003;
    for (int k = 0; k < 100; ++k) {  // 100 ms: 2 mm, the velocity estimate has converged
      d.tip[1] = on_duct(task, x0 + speed * d.t_s, 0.0005);
      d.step();
    }
    d.tip[1] = on_duct(task, x0 + speed * d.t_s, 0.0005);
    d.grip[1] = kGripClosed;
    d.step();
    EXPECT_EQ(task.grasp().holding(), held);
    EXPECT_EQ(task.clips_applied(), held ? 1 : 0) << (held ? "held" : "loose");
    EXPECT_EQ(task.clips_missed(), held ? 0 : 1) << (held ? "held" : "loose");
  }
}

TEST(ClipTaskTest, ThirdClipCompletesTheTaskOnce) {
  ClipTask task(6, reliable());
  VeDriver d(task);
  for (int k = 0; k < ClipTask::kClipsPerDuct; ++k) {
    EXPECT_FALSE(task.complete());
    d.tip[1] = on_duct(task, task.marker_x_m(k), 0.0005);
    settle(d);
    close_and_open(d);
    EXPECT_EQ(task.clips_applied(), k + 1);
  }
  EXPECT_TRUE(task.complete());
  ASSERT_EQ(d.count(TaskEventType::kTaskComplete, -1), 1);
  int clip = 0;
  for (std::size_t k = 0; k < d.events.size(); ++k) {
    const TaskEvent& e = d.events[k];
    if (e.type == TaskEventType::kClipApplied) {
      EXPECT_EQ(e.index, clip++);
    }
    if (e.type == TaskEventType::kTaskComplete) {
      EXPECT_EQ(clip, 3) << "complete before the third clip";
      EXPECT_EQ(e.t_s, d.events[k - 1].t_s) << "in the update of the third clip";
    }
  }
  // More closing does nothing: no fourth clip, no miss, no second completion.
  close_and_open(d);
  EXPECT_EQ(task.clips_applied(), 3);
  EXPECT_EQ(task.clips_missed(), 0);
  EXPECT_EQ(d.count(TaskEventType::kTaskComplete), 1);
}

TEST(ClipTaskTest, TheVeFailsToRegisterAboutOneCorrectClipInTwenty) {
  // Default detection_failure = 5 %. 400 correct first clips on 400 layouts:
  // misses are Binomial(400, 0.05), mean 20, sd 4.4; 6..38 is more than
  // ±3 sd (a false alarm about once in 500 runs of a changed seed set, never
  // for this fixed one).
  int missed = 0;
  for (std::uint64_t seed = 1; seed <= 400; ++seed) {
    ClipTask task(seed);
    VeDriver d(task);
    d.tip[1] = on_duct(task, task.marker_x_m(0), 0.0005);
    d.step();
    d.grip[1] = kGripClosed;
    d.step();
    ASSERT_EQ(task.clips_applied() + task.clips_missed(), 1);
    missed += task.clips_missed();
  }
  EXPECT_GE(missed, 6);
  EXPECT_LE(missed, 38);
}

}  // namespace
}  // namespace hapticlab
