// Tissue contact: the spring–damper law and the per-tool event bookkeeping.
#include "core/sim/contact.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "core/loop/workspace.h"

namespace hapticlab {
namespace {

constexpr double kTolerance_N = 1e-12;

std::vector<TaskEvent> events_of(const EventBuffer& b) {
  std::vector<TaskEvent> out;
  for (int k = 0; k < b.size(); ++k) out.push_back(b[k]);
  return out;
}

TEST(ContactForceTest, SpringDamperAlongTheNormalInsideTheTissue) {
  const ContactParams p{220.0, 1.5};
  const Eigen::Vector3d n = Eigen::Vector3d(1.0, -2.0, 2.0).normalized();
  for (double depth_m : {1e-4, 1e-3, 4e-3}) {
    for (double rate : {-0.01, 0.0, 0.02}) {
      const Eigen::Vector3d f = contact_force(p, depth_m, rate, n);
      const double expected = 220.0 * depth_m + 1.5 * rate;
      ASSERT_GT(expected, 0.0);
      EXPECT_NEAR(f.dot(n), expected, kTolerance_N) << depth_m << " " << rate;
      EXPECT_NEAR((f - f.dot(n) * n).norm(), 0.0, kTolerance_N);  // nothing tangential
    }
  }
  // 1 N at about 4.5 mm: soft tissue.
  EXPECT_NEAR(contact_force(p, 0.0045, 0.0, Eigen::Vector3d::UnitZ()).z(), 0.99, 1e-9);
}

TEST(ContactForceTest, ZeroOutsideTheTissueWhateverTheRate) {
  const ContactParams p{300.0, 2.0};
  for (double depth_m : {0.0, -1e-6, -0.01})
    for (double rate : {-1.0, 0.0, 1.0})
      EXPECT_EQ(contact_force(p, depth_m, rate, Eigen::Vector3d::UnitZ()), Eigen::Vector3d::Zero());
}

TEST(ContactForceTest, NeverPullsTheToolIn) {
  const ContactParams p{250.0, 2.0};
  // Withdrawing fast from a shallow indentation: k·d + b·ḋ < 0 is clipped to 0.
  const Eigen::Vector3d f = contact_force(p, 0.001, -0.5, Eigen::Vector3d::UnitY());
  EXPECT_EQ(f, Eigen::Vector3d::Zero());
  // Just at the sign change and beyond, the force only ever points outward.
  for (double rate = -0.2; rate <= 0.0; rate += 0.01) {
    const Eigen::Vector3d g = contact_force(p, 0.001, rate, Eigen::Vector3d::UnitY());
    EXPECT_GE(g.y(), 0.0) << rate;
  }
}

TEST(ToolTrackerTest, InsertionMarkEventsOncePerCrossing) {
  ToolTracker tracker;
  EventBuffer events;
  std::vector<TaskEvent> all;
  // In to 30 mm, hold, out to 10 mm, hold, in again: instrument 1 only.
  const double profile_m[] = {0.005, 0.015, 0.0199, 0.020, 0.025, 0.030, 0.030,
                              0.021, 0.0195, 0.010, 0.010, 0.022};
  double t = 0.0;
  for (double q : profile_m) {
    events.clear();
    tracker.update(1, t, q, false, events);
    for (const TaskEvent& e : events_of(events)) all.push_back(e);
    t += 0.1;
  }
  ASSERT_EQ(all.size(), 3u);
  EXPECT_EQ(all[0].type, TaskEventType::kInsertionPassed);
  EXPECT_DOUBLE_EQ(all[0].t_s, 0.3);  // at exactly 20 mm
  EXPECT_EQ(all[1].type, TaskEventType::kInsertionWithdrawn);
  EXPECT_DOUBLE_EQ(all[1].t_s, 0.8);
  EXPECT_EQ(all[2].type, TaskEventType::kInsertionPassed);
  for (const TaskEvent& e : all) EXPECT_EQ(e.instrument, 1);
}

TEST(ToolTrackerTest, ContactStartAndEndOncePerTransitionPerTool) {
  ToolTracker tracker;
  EventBuffer events;
  std::vector<TaskEvent> all;
  EXPECT_EQ(tracker.last_contact_s(), -1.0);
  const bool left[] = {false, true, true, true, false, false, true};
  const bool right[] = {false, false, true, false, false, true, true};
  for (int k = 0; k < 7; ++k) {
    events.clear();
    tracker.update(0, k, 0.05, left[k], events);
    tracker.update(1, k, 0.05, right[k], events);
    for (const TaskEvent& e : events_of(events)) all.push_back(e);
  }
  // k=0: both pass the 20 mm mark (start at 50 mm).
  struct Expected {
    double t;
    TaskEventType type;
    int tool;
  };
  const std::vector<Expected> expected = {
      {0, TaskEventType::kInsertionPassed, 0}, {0, TaskEventType::kInsertionPassed, 1},
      {1, TaskEventType::kContactStart, 0},    {2, TaskEventType::kContactStart, 1},
      {3, TaskEventType::kContactEnd, 1},      {4, TaskEventType::kContactEnd, 0},
      {5, TaskEventType::kContactStart, 1},    {6, TaskEventType::kContactStart, 0}};
  ASSERT_EQ(all.size(), expected.size());
  for (std::size_t k = 0; k < all.size(); ++k) {
    EXPECT_EQ(all[k].t_s, expected[k].t) << k;
    EXPECT_EQ(all[k].type, expected[k].type) << k;
    EXPECT_EQ(all[k].instrument, expected[k].tool) << k;
  }
  EXPECT_TRUE(tracker.in_contact(0));
  EXPECT_TRUE(tracker.in_contact(1));
  EXPECT_EQ(tracker.last_contact_s(), 6.0);
}

TEST(ToolTrackerTest, TipVelocityConvergesToTheTrueVelocity) {
  ToolTracker tracker;
  const Eigen::Vector3d v_true(0.01, -0.02, 0.005);
  const double dt = 1e-3;
  Eigen::Vector3d v = tracker.tip_velocity(0, Eigen::Vector3d::Zero(), dt);
  EXPECT_EQ(v, Eigen::Vector3d::Zero());  // nothing to difference yet
  for (int k = 1; k <= 200; ++k) v = tracker.tip_velocity(0, v_true * (k * dt), dt);
  EXPECT_NEAR((v - v_true).norm(), 0.0, 1e-9);
  // The other tool is independent.
  EXPECT_EQ(tracker.tip_velocity(1, Eigen::Vector3d(0.1, 0.1, 0.1), dt), Eigen::Vector3d::Zero());
  // A zero dt (a deferred update) does not divide by zero.
  v = tracker.tip_velocity(0, v_true * 0.5, 0.0);
  EXPECT_TRUE(v.allFinite());
}

}  // namespace
}  // namespace hapticlab
