#pragma once
// Test helper: drives a simulated VE directly with scripted tool tips (world
// frame) and grips, one update per step(), collecting every event.
#include <array>
#include <vector>

#include <Eigen/Core>

#include "core/loop/virtual_environment.h"
#include "core/loop/workspace.h"

namespace hapticlab::testing_sim {

inline constexpr double kGripOpen = 0.30;    // well above kGripOpen_rad
inline constexpr double kGripClosed = 0.02;  // well below kGripClosed_rad

struct VeDriver {
  explicit VeDriver(VirtualEnvironment& ve_in) : ve(ve_in) {
    tip[0] = Eigen::Vector3d(-0.03, 0.0, -0.06);  // parked high above the work area
    tip[1] = Eigen::Vector3d(0.03, 0.0, -0.06);
  }

  // One update of dt_s with the current tips and grips.
  const VeOutput& step(double dt_s = 1e-3) {
    VeInput in;
    in.t_s = t_s;
    in.dt_s = dt_s;
    for (int i = 0; i < 2; ++i) {
      const auto ui = static_cast<std::size_t>(i);
      const JointVector q = joints_for_tip(i, tip[ui]);
      in.joints[ui] = {q[0], q[1], q[2], 0.0, grip[ui]};
      in.tip_m[ui] = tip_world(i, q);
    }
    EventBuffer buffer;
    out = VeOutput{};
    ve.step(in, out, buffer);
    for (int k = 0; k < buffer.size(); ++k) events.push_back(buffer[k]);
    t_s += dt_s;
    return out;
  }
  // Steps until `done()` or `max_steps`; returns the steps taken.
  template <typename Done>
  int step_until(Done done, int max_steps, double dt_s = 1e-3) {
    for (int k = 0; k < max_steps; ++k) {
      step(dt_s);
      if (done()) return k + 1;
    }
    return max_steps;
  }
  int count(TaskEventType type, int instrument = -2) const {
    int n = 0;
    for (const TaskEvent& e : events)
      if (e.type == type && (instrument == -2 || e.instrument == instrument)) ++n;
    return n;
  }

  VirtualEnvironment& ve;
  std::array<Eigen::Vector3d, 2> tip;
  std::array<double, 2> grip{kGripOpen, kGripOpen};
  double t_s = 0.0;
  VeOutput out;
  std::vector<TaskEvent> events;
};

}  // namespace hapticlab::testing_sim
