#pragma once
// CSV of haptic-loop samples: one row per update, both instruments side by
// side, with the task events of that update in the last column.
//
// Columns: tick, t_s, dt_s, device_status, then for p in left_, right_:
//   p raw_insertion_m raw_pitch_rad raw_yaw_rad raw_twist_rad raw_grip_rad
//   p degraded_insertion_m degraded_pitch_rad degraded_yaw_rad
//   p tip_x_m tip_y_m tip_z_m  p tip_vx_m_per_s tip_vy_m_per_s tip_vz_m_per_s
//   p ve_force_x_N ve_force_y_N ve_force_z_N
//   p displayed_force_x_N displayed_force_y_N displayed_force_z_N
//   p insertion_force_N pitch_torque_Nm yaw_torque_Nm  p engine_status p contact
// and events: "left:contact_start;task:task_complete" (instrument or "task",
// event name, and "#index" for tissue cells and clips).
// Numbers are written in the shortest form that reads back to the same
// double (core/common/csv_format.h, as every HapticLab CSV).

#include <deque>
#include <ostream>
#include <string>

#include "core/loop/loop_sample.h"
#include "core/sim/task_event.h"

namespace hapticlab {

class LoopSampleCsvWriter {
 public:
  explicit LoopSampleCsvWriter(std::ostream& out);
  // Events must arrive no later than the sample of their update.
  void add_event(const TaskEvent& event);
  void write(const LoopSample& sample);

 private:
  std::ostream& out_;
  std::deque<TaskEvent> pending_;
  std::string line_;
};

}  // namespace hapticlab
