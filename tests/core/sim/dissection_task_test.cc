// The dissection task (thesis 3.3.2.1): the hidden line's layout, the tissue
// contact force, cautery that removes covering tissue only above its force
// threshold (faster under the grasper's tension), completion when the whole
// line is exposed, and the events of all of it.
//
// The tools are scripted through VeDriver (ve_driver.h) and held still, so
// the tip velocity estimate is exactly zero and every contact force is the
// spring alone, k·depth. Hand-worked numbers for the defaults
// (DissectionParams): cover k = 220 N/m, burn threshold 0.2 N, burn rate
// 5 /s at twice the threshold, grasp k = 120 N/m, tension reference 0.5 N.
#include "core/sim/dissection_task.h"

#include <cmath>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "ve_driver.h"

namespace hapticlab {
namespace {

using testing_sim::kGripClosed;
using testing_sim::kGripOpen;
using testing_sim::VeDriver;

constexpr double kDt_s = 1e-3;
// Forces from tips that went through joints_for_tip/tip_world (a trig round
// trip, ~1e-16 m) times a few hundred N/m.
constexpr double kForceTolerance_N = 1e-9;
constexpr double kCoverThickness_m = 0.002;  // dissection_task.cc

// A point on the covering tissue's surface, `depth_m` below it.
Eigen::Vector3d below_surface(const DissectionTask& task, Eigen::Vector3d p, double depth_m) {
  p.z() = task.params().surface_z_m - depth_m;
  return p;
}

int first_event_index(const VeDriver& d, TaskEventType type, int instrument) {
  for (std::size_t k = 0; k < d.events.size(); ++k)
    if (d.events[k].type == type && d.events[k].instrument == instrument) return static_cast<int>(k);
  return -1;
}

// A cell away from the line and from the left tool's grasp site.
int off_line_cell(const DissectionTask& task, const std::set<int>& avoid = {}) {
  const std::set<int> line(task.line_path().begin(), task.line_path().end());
  for (double x = 0.024; x > -0.024; x -= 0.002) {
    for (double y : {0.017, -0.017, 0.013, -0.013}) {
      const int c = task.cell_at(x, y);
      if (c >= 0 && !line.count(c) && !avoid.count(c)) return c;
    }
  }
  ADD_FAILURE() << "no cell off the line";
  return 0;
}

TEST(DissectionTaskTest, LineRunsFromTheLeftMarkerToTheRightWithABranchFromItsMiddle) {
  std::set<std::vector<int>> layouts;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const DissectionTask task(seed);
    const auto& path = task.line_path();
    ASSERT_GT(task.branch_start(), 0);
    ASSERT_LT(task.branch_start(), task.line_cell_count());
    EXPECT_EQ(task.remaining_line_cells(), task.line_cell_count());
    EXPECT_FALSE(task.complete());
    EXPECT_EQ(std::set<int>(path.begin(), path.end()).size(), path.size()) << "cells repeat";

    // Sampled every 0.4 mm on a 2 mm grid, a line moves to one of the 8
    // neighbouring cells at each step: it is connected.
    auto neighbours = [&](int a, int b) {
      const Eigen::Vector3d d = task.cell_center(a) - task.cell_center(b);
      return std::abs(d.x()) <= 0.002 + 1e-12 && std::abs(d.y()) <= 0.002 + 1e-12;
    };
    for (std::size_t k = 1; k < path.size(); ++k) {
      if (static_cast<int>(k) == task.branch_start()) continue;
      EXPECT_TRUE(neighbours(path[k - 1], path[k])) << "seed " << seed << " cell " << k;
    }
    // The marker end lies 5 mm in from the left edge (x = -25 mm), the main
    // line ends 5 mm in from the right edge: within half a cell.
    const double half_cell = 0.001 + 1e-12;
    EXPECT_NEAR(task.cell_center(path.front()).x(), -0.025, half_cell);
    EXPECT_NEAR(task.cell_center(path[static_cast<std::size_t>(task.branch_start() - 1)]).x(), 0.025,
                half_cell);
    // The branch leaves from the main line's midpoint (x = 0; its first own
    // cell is within two cells of it) ...
    const int junction = path[static_cast<std::size_t>(task.branch_start())];
    bool attached = false;
    for (int k = 0; k < task.branch_start(); ++k)
      attached = attached || neighbours(junction, path[static_cast<std::size_t>(k)]);
    EXPECT_TRUE(attached) << "seed " << seed;
    EXPECT_NEAR(task.cell_center(junction).x(), 0.0, 0.004 + 1e-12);
    // ... and runs 8-14 mm on to the right (less a cell for where the
    // junction cell sits), to the front or the back.
    const Eigen::Vector3d branch = task.cell_center(path.back()) - task.cell_center(junction);
    EXPECT_GE(branch.x(), 0.006) << "seed " << seed;
    EXPECT_GE(branch.norm(), 0.008) << "seed " << seed;
    layouts.insert(path);
  }
  EXPECT_EQ(layouts.size(), 20u) << "the layout seed must vary the line";
  // Same seed, same line.
  EXPECT_EQ(DissectionTask(7).line_path(), DissectionTask(7).line_path());
}

TEST(DissectionTaskTest, CellLookupIsTheInverseOfCellCentres) {
  const DissectionTask task(3);
  const auto& p = task.params();
  EXPECT_EQ(task.cell_at(-p.half_width_x_m - 1e-4, 0.0), -1);
  EXPECT_EQ(task.cell_at(0.0, p.half_width_y_m + 1e-4), -1);
  for (int c = 0; c < 30 * 20; c += 37) {
    const Eigen::Vector3d center = task.cell_center(c);
    EXPECT_EQ(task.cell_at(center.x(), center.y()), c);
    EXPECT_EQ(task.cell_at(center.x() + 0.0009, center.y() - 0.0009), c);
    EXPECT_DOUBLE_EQ(center.z(), p.surface_z_m);
  }
}

TEST(DissectionTaskTest, ContactForceIsTheCoverSpringThenTheStructureBelowIt) {
  DissectionTask task(1);
  VeDriver d(task);
  const int cell = off_line_cell(task);
  // 3 mm into the cover: 220 N/m · 3 mm = 0.66 N straight up.
  d.tip[1] = below_surface(task, task.cell_center(cell), 0.003);
  d.step();
  EXPECT_NEAR(d.out.tip_force_N[1].z(), 0.66, kForceTolerance_N);
  EXPECT_NEAR(d.out.tip_force_N[1].head<2>().norm(), 0.0, kForceTolerance_N);
  EXPECT_TRUE(d.out.in_contact[1]);
  // The parked left tool touches nothing.
  EXPECT_EQ(d.out.tip_force_N[0], Eigen::Vector3d::Zero());
  EXPECT_FALSE(d.out.in_contact[0]);
  // 3 mm above: nothing.
  d.tip[1] = below_surface(task, task.cell_center(cell), -0.003);
  d.step();
  d.step();  // the tip velocity estimate has seen the jump; hold still
  for (int k = 0; k < 200; ++k) d.step();
  EXPECT_EQ(d.out.tip_force_N[1], Eigen::Vector3d::Zero());
  EXPECT_FALSE(d.out.in_contact[1]);
}

TEST(DissectionTaskTest, CauteryBelowTheForceThresholdNeverRemovesTissue) {
  // 0.5 mm → 0.11 N and 0.9 mm → 0.198 N, both below the 0.2 N threshold:
  // held for 3 s, no cell loses anything visible.
  for (double depth_m : {0.0005, 0.0009}) {
    DissectionTask task(2);
    VeDriver d(task);
    d.tip[1] = below_surface(task, task.cell_center(task.line_path()[3]), depth_m);
    for (int k = 0; k < 3000; ++k) d.step(kDt_s);
    EXPECT_NEAR(d.out.tip_force_N[1].z(), 220.0 * depth_m, kForceTolerance_N);
    EXPECT_EQ(d.count(TaskEventType::kTissueRemoved), 0) << depth_m;
    EXPECT_EQ(task.remaining_line_cells(), task.line_cell_count());
    EXPECT_FALSE(task.removed(task.line_path()[3]));
  }
}

TEST(DissectionTaskTest, CauteryAboveTheThresholdRemovesTheCellAtTheHandWorkedTime) {
  // 1.5 mm → f = 0.33 N; rate = 5 /s · (0.33 − 0.2)/0.2 = 3.25 /s of a health
  // of 1, i.e. 3.25e-3 per 1 ms update: 307 updates leave 0.00225, the 308th
  // (index 307, t = 0.307 s) takes it below zero.
  DissectionTask task(4);
  VeDriver d(task);
  const int cell = off_line_cell(task);
  d.tip[1] = below_surface(task, task.cell_center(cell), 0.0015);
  d.step_until([&] { return task.removed(cell); }, 1000, kDt_s);
  ASSERT_TRUE(task.removed(cell));
  EXPECT_NEAR(d.t_s - kDt_s, 0.307, 1e-12) << "removed at the wrong update";
  // Only that cell: its neighbours' centres are 2 mm away, beyond the 1.6 mm
  // burn radius. Off the line, the task is no closer to completion.
  EXPECT_EQ(d.count(TaskEventType::kTissueRemoved), 1);
  EXPECT_EQ(task.remaining_line_cells(), task.line_cell_count());

  // Events so far: both tools start past the 20 mm mark, the right one in
  // contact, then the cell goes.
  ASSERT_EQ(d.events.size(), 4u);
  EXPECT_EQ(d.events[0].type, TaskEventType::kInsertionPassed);
  EXPECT_EQ(d.events[0].instrument, 0);
  EXPECT_EQ(d.events[1].type, TaskEventType::kInsertionPassed);
  EXPECT_EQ(d.events[1].instrument, 1);
  EXPECT_EQ(d.events[2].type, TaskEventType::kContactStart);
  EXPECT_EQ(d.events[2].instrument, 1);
  EXPECT_EQ(d.events[2].t_s, 0.0);
  EXPECT_EQ(d.events[3].type, TaskEventType::kTissueRemoved);
  EXPECT_EQ(d.events[3].instrument, 1);
  EXPECT_EQ(d.events[3].index, cell);
  EXPECT_NEAR(d.events[3].t_s, 0.307, 1e-12);

  // The structure lies 2 mm below the cover's surface: the tip, 1.5 mm down,
  // now hangs 0.5 mm above it — no force, contact ends on the next update.
  d.step(kDt_s);
  EXPECT_EQ(d.out.tip_force_N[1], Eigen::Vector3d::Zero());
  ASSERT_EQ(d.events.size(), 5u);
  EXPECT_EQ(d.events[4].type, TaskEventType::kContactEnd);
  // Pressing on into the exposed structure meets its stiffer spring:
  // 320 N/m at 1 mm below the structure surface = 0.32 N.
  d.tip[1] = below_surface(task, task.cell_center(cell), kCoverThickness_m + 0.001);
  // Held still, the velocity estimate of the 1 mm jump decays by a factor
  // 0.76 per update (50 Hz filter): after 100 updates the damper adds ~1e-12 N.
  for (int k = 0; k < 100; ++k) d.step(kDt_s);
  EXPECT_NEAR(d.out.tip_force_N[1].z(), 0.32, kForceTolerance_N);
}

TEST(DissectionTaskTest, TipOnACellCornerBurnsTheFourCellsAroundIt) {
  // The corner is √2 mm ≈ 1.41 mm from the four centres, inside the 1.6 mm
  // burn radius: all four go in the same update.
  DissectionTask task(5);
  VeDriver d(task);
  const int cell = off_line_cell(task);
  const Eigen::Vector3d corner = task.cell_center(cell) + Eigen::Vector3d(0.001, 0.001, 0.0);
  d.tip[1] = below_surface(task, corner, 0.0015);
  d.step_until([&] { return d.count(TaskEventType::kTissueRemoved) > 0; }, 1000, kDt_s);
  EXPECT_NEAR(d.t_s - kDt_s, 0.307, 1e-12);
  std::set<int> removed;
  for (const TaskEvent& e : d.events)
    if (e.type == TaskEventType::kTissueRemoved) removed.insert(e.index);
  const std::set<int> expected = {cell, cell + 1, cell + 30, cell + 31};  // 30 cells per row
  EXPECT_EQ(removed, expected);
}

TEST(DissectionTaskTest, GrasperTensionDoublesTheBurnRate) {
  // Left grasper closed 5 mm deep in the cover: it takes hold at the surface
  // and the 5 mm stretch pulls with 120 N/m · 5 mm = 0.6 N ≥ the 0.5 N
  // reference, so the burn rate doubles to 6.5 /s (6.5e-3 per update):
  // 153 updates leave 0.0055, the 154th (index 153, t = 0.153 s) removes
  // the cell — versus index 307 without tension (test above).
  DissectionTask task(6);
  VeDriver d(task);
  const int cell = off_line_cell(task);
  const Eigen::Vector3d grasp_site = task.cell_center(off_line_cell(task, {cell, cell - 1, cell + 1}));
  ASSERT_GT((grasp_site - task.cell_center(cell)).norm(), 0.004);
  d.tip[0] = below_surface(task, grasp_site, 0.005);
  d.grip[0] = kGripClosed;
  d.tip[1] = below_surface(task, task.cell_center(cell), 0.0015);
  d.step(kDt_s);
  ASSERT_TRUE(task.grasp().holding());
  EXPECT_NEAR(task.tension_N(), 0.6, kForceTolerance_N);
  // On the left tip: cover spring 220 · 5 mm = 1.1 N plus the grasp's 0.6 N.
  EXPECT_NEAR(d.out.tip_force_N[0].z(), 1.7, kForceTolerance_N);
  EXPECT_TRUE(d.out.in_contact[0]);
  EXPECT_EQ(d.count(TaskEventType::kGraspStart, 0), 1);

  d.step_until([&] { return task.removed(cell); }, 1000, kDt_s);
  ASSERT_TRUE(task.removed(cell));
  EXPECT_NEAR(d.t_s - kDt_s, 0.153, 1e-12);

  // Opening the jaws lets go: no tension, one grasp_end.
  d.grip[0] = kGripOpen;
  d.step(kDt_s);
  EXPECT_FALSE(task.grasp().holding());
  EXPECT_EQ(task.tension_N(), 0.0);
  EXPECT_NEAR(d.out.tip_force_N[0].z(), 1.1, kForceTolerance_N);
  EXPECT_EQ(d.count(TaskEventType::kGraspEnd, 0), 1);
}

TEST(DissectionTaskTest, GraspedTissuePullsBackAndTearsFreeBeyondItsStretch) {
  DissectionTask task(8);
  VeDriver d(task);
  const Eigen::Vector3d site = task.cell_center(off_line_cell(task));
  d.tip[0] = below_surface(task, site, 0.001);
  d.grip[0] = kGripClosed;
  d.step();
  ASSERT_TRUE(task.grasp().holding());
  // Pulled 10 mm up and 10 mm sideways from where it was taken (on the
  // surface above the tip): −120 N/m × the stretch, once the tip is still.
  d.tip[0] = site + Eigen::Vector3d(0.010, 0.0, 0.010);
  for (int k = 0; k < 200; ++k) d.step();
  EXPECT_NEAR(d.out.tip_force_N[0].x(), -1.2, kForceTolerance_N);
  EXPECT_NEAR(d.out.tip_force_N[0].z(), -1.2, kForceTolerance_N);
  EXPECT_TRUE(d.out.in_contact[0]) << "holding tissue counts as contact";
  // 30 mm is as far as it stretches.
  d.tip[0] = site + Eigen::Vector3d(0.0, 0.0, 0.031);
  d.step();
  EXPECT_FALSE(task.grasp().holding());
  EXPECT_EQ(d.count(TaskEventType::kGraspEnd, 0), 1);
}

TEST(DissectionTaskTest, ExposingEveryLineCellCompletesTheTaskOnce) {
  DissectionTask task(9);
  VeDriver d(task);
  const auto path = task.line_path();
  // Follow the line cell by cell, 1.5 mm deep at each centre until it goes.
  for (std::size_t k = 0; k < path.size(); ++k) {
    const int cell = path[k];
    if (task.removed(cell)) continue;
    EXPECT_FALSE(task.complete()) << "complete with cell " << k << " of " << path.size() << " left";
    d.tip[1] = below_surface(task, task.cell_center(cell), 0.0015);
    d.step_until([&] { return task.removed(cell); }, 2000, kDt_s);
    ASSERT_TRUE(task.removed(cell)) << k;
    EXPECT_EQ(task.remaining_line_cells(), static_cast<int>(path.size() - k - 1));
  }
  EXPECT_TRUE(task.complete());
  EXPECT_EQ(task.remaining_line_cells(), 0);
  EXPECT_EQ(d.count(TaskEventType::kTissueRemoved), static_cast<int>(path.size()));
  ASSERT_EQ(d.count(TaskEventType::kTaskComplete), 1);
  const int done = first_event_index(d, TaskEventType::kTaskComplete, -1);
  ASSERT_GE(done, 0);
  // Reported in the update that removed the last cell.
  EXPECT_EQ(d.events[static_cast<std::size_t>(done)].t_s, d.events[static_cast<std::size_t>(done - 1)].t_s);
  EXPECT_EQ(d.events[static_cast<std::size_t>(done - 1)].index, path.back());
  // Burning on does not report completion again.
  d.tip[1] = below_surface(task, task.cell_center(off_line_cell(task)), 0.0015);
  for (int k = 0; k < 500; ++k) d.step();
  EXPECT_EQ(d.count(TaskEventType::kTaskComplete), 1);
}

}  // namespace
}  // namespace hapticlab
