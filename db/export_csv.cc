#include "db/export_csv.h"

#include <cctype>
#include <stdexcept>
#include <string>

#include "core/common/csv_format.h"
#include "core/io/output_file.h"
#include "db/sample_codec.h"

namespace hapticlab::db {
namespace {

std::string slug(std::string_view text) {
  std::string out;
  for (char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (std::isalnum(c) || c == '-') out += static_cast<char>(std::tolower(c));
    else if (!out.empty() && out.back() != '_') out += '_';
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  return out.empty() ? "_" : out;
}

// One export file, complete or absent (core/io/output_file.h): a full disk
// names the file and the cause, and leaves no truncated CSV.
class CsvFile {
 public:
  explicit CsvFile(std::filesystem::path path) : file_(std::move(path)) {}
  void line(std::string& text) {
    text += '\n';
    file_.stream().write(text.data(), static_cast<std::streamsize>(text.size()));
    text.clear();
  }
  void commit() { file_.commit(); }
  const std::filesystem::path& path() const { return file_.path(); }

 private:
  AtomicOutputFile file_;
};

void put_trial_key(std::string& line, const TrialRow& t) {
  append_number(line, t.id);
  line += ',';
  append_csv_text(line, t.participant_code);
  line += ',';
  append_csv_text(line, t.task);
  line += ',';
  append_csv_text(line, t.setting_name);
  line += ',';
  append_number(line, t.repetition);
}

void put_sample(std::string& line, const StoredSample& s) {
  const InstrumentSample& v = s.value;
  line += ',';
  append_number(line, s.tick);
  line += ',';
  append_number(line, s.dt_s);
  line += ',';
  append_number(line, s.t_s);
  // Stored as float32: printing the float keeps the text short and exact.
  auto f = [&](double x) {
    line += ',';
    append_number(line, to_stored_float(x));
  };
  for (double x : v.raw_position) f(x);
  for (double x : v.degraded_position) f(x);
  for (double x : v.tip_position_m) f(x);
  for (double x : v.tip_velocity_m_per_s) f(x);
  for (double x : v.ve_force_N) f(x);
  for (double x : v.displayed_force_N) f(x);
  for (double x : v.joint_force) f(x);
  line += ',';
  append_number(line, v.engine_status);
  line += ',';
  append_number(line, s.device_status);
  line += v.in_contact ? ",1" : ",0";
}

// Damaged chunks with nobody to report them to are an error.
void refuse_unreported(const StudyDb& db, const std::vector<BadChunk>& bad) {
  if (bad.empty()) return;
  std::string list;
  for (const BadChunk& c : bad) list += "; " + describe(c);
  throw DbError(db.path() + ": " + std::to_string(bad.size()) + " damaged sample chunk(s)" + list);
}

std::filesystem::path trial_stem(const std::filesystem::path& dir, const TrialRow& t) {
  return dir / (slug(t.participant_code) + "_" + slug(t.task) + "_" + slug(t.setting_name) + "_rep" +
                std::to_string(t.repetition) + "_trial" + std::to_string(t.id));
}

}  // namespace

std::vector<std::filesystem::path> export_trial_csv(StudyDb& db, std::int64_t trial_id,
                                                    const std::filesystem::path& out_dir,
                                                    std::vector<BadChunk>* bad_chunks) {
  const TrialRow t = db.trial(trial_id);
  std::filesystem::create_directories(out_dir);
  const std::string stem = trial_stem(out_dir, t).string();
  std::string line;

  CsvFile samples(stem + "_samples.csv");
  line = "trial_id,participant,task,setting,repetition,instrument,tick";
  for (const char* name : kChannelNames) line += std::string(",") + name;
  samples.line(line);
  std::vector<StoredSample> left, right;
  std::vector<BadChunk> bad;
  read_samples(db.connection(), trial_id, 0, left, bad);
  read_samples(db.connection(), trial_id, 1, right, bad);
  if (bad_chunks == nullptr) refuse_unreported(db, bad);
  else bad_chunks->insert(bad_chunks->end(), bad.begin(), bad.end());
  // Merge by tick, left first within a tick.
  std::size_t i = 0, k = 0;
  while (i < left.size() || k < right.size()) {
    const bool take_left = k == right.size() || (i < left.size() && left[i].tick <= right[k].tick);
    const StoredSample& s = take_left ? left[i++] : right[k++];
    put_trial_key(line, t);
    line += take_left ? ",0" : ",1";
    put_sample(line, s);
    samples.line(line);
  }

  CsvFile events(stem + "_events.csv");
  line = "trial_id,participant,task,setting,repetition,t_s,type,instrument,index,detail";
  events.line(line);
  for (const EventRow& e : db.events(trial_id)) {
    put_trial_key(line, t);
    line += ',';
    append_number(line, e.t_s);
    line += ',';
    append_csv_text(line, e.type);
    line += ',';
    append_number(line, e.instrument);
    line += ',';
    append_number(line, e.item_index);
    line += ',';
    append_csv_text(line, e.detail);
    events.line(line);
  }
  samples.commit();
  events.commit();
  return {samples.path(), events.path()};
}

std::vector<std::filesystem::path> export_study_csv(StudyDb& db, std::int64_t study_id,
                                                    const std::filesystem::path& out_dir,
                                                    std::vector<BadChunk>* bad_chunks) {
  std::filesystem::create_directories(out_dir);
  std::vector<std::filesystem::path> written;
  CsvFile index(out_dir / "trials.csv");
  std::string line =
      "trial_id,participant,task,setting,repetition,block,position,status,started_unix_s,ended_unix_s,"
      "abort_reason,updates,loop_count,loop_p50_period_s,loop_p99_period_s,loop_max_period_s,"
      "loop_mean_period_s,loop_overruns,dropped_samples,dropped_events,device_counters";
  index.line(line);
  for (const TrialRow& t : db.trials(study_id)) {
    put_trial_key(line, t);
    line += ',';
    append_number(line, t.block);
    line += ',';
    append_number(line, t.position);
    line += ',';
    line += to_string(t.status);
    line += ',';
    if (t.started_unix_s) append_number(line, *t.started_unix_s);
    line += ',';
    if (t.ended_unix_s) append_number(line, *t.ended_unix_s);
    line += ',';
    append_csv_text(line, t.abort_reason);
    line += ',';
    append_number(line, db.sample_count(t.id, 0));
    const std::optional<LoopTimingRow> timing = db.loop_timing(t.id);
    if (timing && timing->timing) {
      const LoopTimingSummary& s = *timing->timing;
      for (double x : {static_cast<double>(s.count), s.p50_period_s, s.p99_period_s, s.max_period_s,
                       s.mean_period_s, static_cast<double>(s.overruns)}) {
        line += ',';
        append_number(line, x);
      }
    } else {
      line += ",,,,,,";
    }
    line += ',';
    if (timing) append_number(line, timing->dropped_samples);
    line += ',';
    if (timing) append_number(line, timing->dropped_events);
    // The device's own counts (device_counter), as name=value;... : one
    // column whatever the device, empty for devices that count nothing.
    std::string counters;
    for (const auto& [name, value] : db.device_counters(t.id))
      counters += (counters.empty() ? "" : ";") + name + "=" + std::to_string(value);
    line += ',';
    append_csv_text(line, counters);
    index.line(line);
    if (t.status != TrialStatus::kPlanned) {
      const auto files = export_trial_csv(db, t.id, out_dir, bad_chunks);
      written.insert(written.end(), files.begin(), files.end());
    }
  }
  index.commit();
  written.push_back(index.path());
  return written;
}

}  // namespace hapticlab::db
