#include "core/io/loop_sample_csv.h"

#include "core/common/csv_format.h"

namespace hapticlab {

namespace {

// Shortest round-trip numbers (core/common/csv_format.h), each followed by
// the separator.
void append_real(std::string& line, double v) {
  append_number(line, v);
  line.push_back(',');
}

void append_integer(std::string& line, long long v) {
  append_number(line, v);
  line.push_back(',');
}

}  // namespace

LoopSampleCsvWriter::LoopSampleCsvWriter(std::ostream& out) : out_(out) {
  std::string header = "tick,t_s,dt_s,device_status";
  for (const char* p : {"left_", "right_"}) {
    for (const char* c :
         {"raw_insertion_m", "raw_pitch_rad", "raw_yaw_rad", "raw_twist_rad", "raw_grip_rad",
          "degraded_insertion_m", "degraded_pitch_rad", "degraded_yaw_rad", "tip_x_m", "tip_y_m",
          "tip_z_m", "tip_vx_m_per_s", "tip_vy_m_per_s", "tip_vz_m_per_s", "ve_force_x_N",
          "ve_force_y_N", "ve_force_z_N", "displayed_force_x_N", "displayed_force_y_N",
          "displayed_force_z_N", "insertion_force_N", "pitch_torque_Nm", "yaw_torque_Nm",
          "engine_status", "contact"}) {
      header += ',';
      header += p;
      header += c;
    }
  }
  header += ",events\n";
  out_ << header;
}

void LoopSampleCsvWriter::add_event(const TaskEvent& event) { pending_.push_back(event); }

void LoopSampleCsvWriter::write(const LoopSample& s) {
  line_.clear();
  append_integer(line_, static_cast<long long>(s.tick));
  append_real(line_, s.t_s);
  append_real(line_, s.dt_s);
  append_integer(line_, s.device_status);
  for (const InstrumentSample& in : s.instrument) {
    for (double v : in.raw_position) append_real(line_, v);
    for (double v : in.degraded_position) append_real(line_, v);
    for (double v : in.tip_position_m) append_real(line_, v);
    for (double v : in.tip_velocity_m_per_s) append_real(line_, v);
    for (double v : in.ve_force_N) append_real(line_, v);
    for (double v : in.displayed_force_N) append_real(line_, v);
    for (double v : in.joint_force) append_real(line_, v);
    append_integer(line_, in.engine_status);
    append_integer(line_, in.in_contact ? 1 : 0);
  }
  bool first = true;
  while (!pending_.empty() && pending_.front().t_s <= s.t_s) {
    const TaskEvent& e = pending_.front();
    if (!first) line_.push_back(';');
    first = false;
    line_ += e.instrument == 0 ? "left:" : e.instrument == 1 ? "right:" : "task:";
    line_ += to_string(e.type);
    if (e.type == TaskEventType::kTissueRemoved || e.type == TaskEventType::kClipApplied ||
        e.type == TaskEventType::kClipMissed) {
      line_.push_back('#');
      line_ += std::to_string(e.index);
    }
    pending_.pop_front();
  }
  line_.push_back('\n');
  out_ << line_;
}

}  // namespace hapticlab
