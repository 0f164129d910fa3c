#include "core/loop/loop_sample_csv.h"

#include "core/common/csv_format.h"
#include "core/loop/sample_channels.h"

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
  std::string header = "instrument,tick";
  for (const char* c : kSampleChannelNames) {
    header += ',';
    header += c;
  }
  header += ",events\n";
  out_ << header;
}

void LoopSampleCsvWriter::add_event(const TaskEvent& event) { pending_.push_back(event); }

void LoopSampleCsvWriter::write(const LoopSample& s) {
  // The update's events, split by instrument (task-wide ones with the left).
  std::string events[2];
  while (!pending_.empty() && pending_.front().t_s <= s.t_s) {
    const TaskEvent& e = pending_.front();
    std::string& text = events[e.instrument == 1 ? 1 : 0];
    if (!text.empty()) text.push_back(';');
    text += e.instrument == 0 ? "left:" : e.instrument == 1 ? "right:" : "task:";
    text += to_string(e.type);
    if (e.type == TaskEventType::kTissueRemoved || e.type == TaskEventType::kClipApplied ||
        e.type == TaskEventType::kClipMissed) {
      text.push_back('#');
      text += std::to_string(e.index);
    }
    pending_.pop_front();
  }
  for (std::size_t i = 0; i < 2; ++i) {
    const InstrumentSample& in = s.instrument[i];
    line_.clear();
    append_integer(line_, static_cast<long long>(i));
    append_integer(line_, static_cast<long long>(s.tick));
    append_real(line_, s.dt_s);
    append_real(line_, s.t_s);
    for (double v : in.raw_position) append_real(line_, v);
    for (double v : in.degraded_position) append_real(line_, v);
    for (double v : in.tip_position_m) append_real(line_, v);
    for (double v : in.tip_velocity_m_per_s) append_real(line_, v);
    for (double v : in.ve_force_N) append_real(line_, v);
    for (double v : in.displayed_force_N) append_real(line_, v);
    for (double v : in.joint_force) append_real(line_, v);
    append_integer(line_, in.engine_status);
    append_integer(line_, s.device_status);
    append_integer(line_, in.in_contact ? 1 : 0);
    line_ += events[i];
    line_.push_back('\n');
    out_ << line_;
  }
}

}  // namespace hapticlab
