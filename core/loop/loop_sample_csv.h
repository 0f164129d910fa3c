#pragma once
// CSV of haptic-loop samples in the long layout every HapticLab sample
// table uses (core/loop/sample_channels.h): one row per instrument and
// update, left before right within an update.
//
// Columns: instrument (0 left, 1 right), tick, then the channels of
// kSampleChannelNames (dt_s, t_s, raw_*, degraded_*, tip_*, ve_force_*,
// displayed_force_*, insertion_force_N, pitch_torque_Nm, yaw_torque_Nm,
// engine_status, device_status, in_contact), then events: the task events
// of that update for that instrument, ';'-separated, as
// "right:tissue_removed#3" (instrument or "task", event name, "#index" for
// tissue cells and clips); events of the task as a whole go in the left
// (instrument 0) row. Values are the loop's doubles (`export` gives the
// database's float32 of the same channels).
// Numbers are written in the shortest form that reads back to the same
// double (core/common/csv_format.h, as every HapticLab CSV).

#include <deque>
#include <ostream>
#include <string>

#include "core/loop/loop_sample.h"
#include "core/loop/task_event.h"

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
