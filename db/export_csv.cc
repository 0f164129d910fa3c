#include "db/export_csv.h"

#include <cctype>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/common/csv_format.h"
#include "core/common/output_file.h"
#include "db/sample_codec.h"

#include <zlib.h>

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

// One export file, complete or absent (core/common/output_file.h): a full disk
// names the file and the cause, and leaves no truncated CSV.
// With gzip, the text goes through zlib's deflate (gzip header, level 6)
// on its way into the file.
class CsvFile {
 public:
  CsvFile(std::filesystem::path path, bool gzip)
      : file_(gzip ? std::filesystem::path(path.string() + ".gz") : std::move(path)), gzip_(gzip) {
    if (gzip_ && deflateInit2(&z_, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
      throw std::runtime_error(file_.path().string() + ": zlib could not start");
  }
  ~CsvFile() {
    if (gzip_) deflateEnd(&z_);
  }
  CsvFile(const CsvFile&) = delete;
  CsvFile& operator=(const CsvFile&) = delete;
  void line(std::string& text) {
    text += '\n';
    if (gzip_) {
      buffer_ += text;
      if (buffer_.size() >= (1u << 16)) deflate_buffer(Z_NO_FLUSH);
    } else {
      file_.stream().write(text.data(), static_cast<std::streamsize>(text.size()));
    }
    text.clear();
  }
  void commit() {
    if (gzip_) deflate_buffer(Z_FINISH);
    file_.commit();
  }
  const std::filesystem::path& path() const { return file_.path(); }

 private:
  void deflate_buffer(int flush) {
    z_.next_in = reinterpret_cast<Bytef*>(buffer_.data());
    z_.avail_in = static_cast<uInt>(buffer_.size());
    char out[1 << 15];
    int rc = Z_OK;
    do {
      z_.next_out = reinterpret_cast<Bytef*>(out);
      z_.avail_out = sizeof out;
      rc = deflate(&z_, flush);
      if (rc == Z_STREAM_ERROR) throw std::runtime_error(file_.path().string() + ": zlib deflate failed");
      file_.stream().write(out, static_cast<std::streamsize>(sizeof out - z_.avail_out));
    } while (z_.avail_out == 0 || (flush == Z_FINISH && rc != Z_STREAM_END));
    buffer_.clear();
  }

  AtomicOutputFile file_;
  bool gzip_;
  z_stream z_{};
  std::string buffer_;
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

// Channel c of kChannelNames (sample_codec.h): dt_s, t_s, then the 23
// float32 channels, then engine_status, device_status, in_contact.
void put_channel(std::string& line, const StoredSample& s, std::size_t c) {
  const InstrumentSample& v = s.value;
  line += ',';
  // Stored as float32: printing the float keeps the text short and exact.
  auto f = [&](double x) { append_number(line, to_stored_float(x)); };
  if (c == 0) append_number(line, s.dt_s);
  else if (c == 1) append_number(line, s.t_s);
  else if (c < 7) f(v.raw_position[c - 2]);
  else if (c < 10) f(v.degraded_position[c - 7]);
  else if (c < 13) f(v.tip_position_m[c - 10]);
  else if (c < 16) f(v.tip_velocity_m_per_s[c - 13]);
  else if (c < 19) f(v.ve_force_N[c - 16]);
  else if (c < 22) f(v.displayed_force_N[c - 19]);
  else if (c < 25) f(v.joint_force[c - 22]);
  else if (c == 25) append_number(line, v.engine_status);
  else if (c == 26) append_number(line, s.device_status);
  else line += v.in_contact ? "1" : "0";
}

std::vector<std::size_t> channels_of(const ExportSelection& selection) {
  if (!selection.channels.empty()) return selection.channels;
  std::vector<std::size_t> all(kChunkChannels);
  for (std::size_t c = 0; c < all.size(); ++c) all[c] = c;
  return all;
}

std::string samples_header(const std::vector<std::size_t>& channels) {
  std::string line = "trial_id,participant,task,setting,repetition,instrument,tick";
  for (std::size_t c : channels) line += std::string(",") + kChannelNames[c];
  return line;
}

const char* const kEventsHeader = "trial_id,participant,task,setting,repetition,t_s,type,instrument,item_index,detail";

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

namespace {

// The trial's sample rows and event rows, appended to the two files.
void write_trial_rows(StudyDb& db, const TrialRow& t, CsvFile& samples, CsvFile& events,
                      std::vector<BadChunk>* bad_chunks, const ExportSelection& selection) {
  const std::vector<std::size_t> channels = channels_of(selection);
  std::string line;
  // Both instruments' chunks streamed and merged by tick, left first
  // within a tick: a window of each in memory, never the trial.
  TrialChunks chunks(db.connection(), t.id);
  std::span<const StoredSample> window[2];
  std::size_t pos[2] = {0, 0};
  for (;;) {
    for (int k = 0; k < 2; ++k)
      if (pos[k] == window[k].size()) {
        window[k] = chunks.next(k);
        pos[k] = 0;
      }
    const bool left = !window[0].empty(), right = !window[1].empty();
    if (!left && !right) break;
    const int k = !right || (left && window[0][pos[0]].tick <= window[1][pos[1]].tick) ? 0 : 1;
    const StoredSample& s = window[k][pos[k]++];
    if (s.tick % selection.every != 0) continue;
    put_trial_key(line, t);
    line += k == 0 ? ",0," : ",1,";
    append_number(line, s.tick);
    for (std::size_t c : channels) put_channel(line, s, c);
    samples.line(line);
  }
  if (bad_chunks == nullptr) refuse_unreported(db, chunks.bad());
  else bad_chunks->insert(bad_chunks->end(), chunks.bad().begin(), chunks.bad().end());
  for (const EventRow& e : db.events(t.id)) {
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
}

bool selected(const TrialRow& t, const ExportSelection& s) {
  return (s.participants.empty() || s.participants.count(t.participant_code)) &&
         (s.settings.empty() || s.settings.count(t.setting_name)) &&
         (s.statuses.empty() || s.statuses.count(to_string(t.status)));
}

}  // namespace

std::optional<std::size_t> channel_index(std::string_view name) {
  for (std::size_t c = 0; c < kChannelNames.size(); ++c)
    if (name == kChannelNames[c]) return c;
  return std::nullopt;
}

std::vector<std::filesystem::path> export_trial_csv(StudyDb& db, std::int64_t trial_id,
                                                    const std::filesystem::path& out_dir,
                                                    std::vector<BadChunk>* bad_chunks,
                                                    const ExportSelection& selection) {
  const TrialRow t = db.trial(trial_id);
  std::filesystem::create_directories(out_dir);
  const std::string stem = trial_stem(out_dir, t).string();
  CsvFile samples(stem + "_samples.csv", selection.gzip);
  CsvFile events(stem + "_events.csv", selection.gzip);
  std::string line = samples_header(channels_of(selection));
  samples.line(line);
  line = kEventsHeader;
  events.line(line);
  write_trial_rows(db, t, samples, events, bad_chunks, selection);
  samples.commit();
  events.commit();
  return {samples.path(), events.path()};
}

namespace {

// One row of trials.csv: the trial, its loop timing and its device's counts.
void trial_index_line(StudyDb& db, const TrialRow& t, std::string& line) {
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
}

// The operator's actions (the console's notes, pauses, STOPs, ...): those
// of the selected participants' sessions; with no participant selected,
// also those of no session (a STOP while none ran).
std::filesystem::path write_operator_actions(StudyDb& db, const std::filesystem::path& out_dir,
                                             const ExportSelection& selection) {
  CsvFile actions(out_dir / "operator_actions.csv", selection.gzip);
  std::string line = "id,session_id,participant,trial_id,unix_s,t_s,type,detail";
  actions.line(line);
  for (const OperatorActionRow& a : db.operator_actions()) {
    if (!selection.participants.empty() && !selection.participants.count(a.participant_code)) continue;
    line.clear();
    append_number(line, a.id);
    line += ',';
    if (a.session_id) append_number(line, *a.session_id);
    line += ',';
    append_csv_text(line, a.participant_code);
    line += ',';
    if (a.trial_id) append_number(line, *a.trial_id);
    line += ',';
    append_number(line, a.unix_s);
    line += ',';
    if (a.t_s) append_number(line, *a.t_s);
    line += ',';
    append_csv_text(line, a.type);
    line += ',';
    append_csv_text(line, a.detail);
    actions.line(line);
  }
  actions.commit();
  return actions.path();
}

}  // namespace

std::vector<std::filesystem::path> export_study_csv(StudyDb& db, std::int64_t study_id,
                                                    const std::filesystem::path& out_dir,
                                                    std::vector<BadChunk>* bad_chunks,
                                                    const ExportSelection& selection) {
  std::filesystem::create_directories(out_dir);
  std::vector<std::filesystem::path> written;
  CsvFile index(out_dir / "trials.csv", selection.gzip);
  std::optional<CsvFile> all_samples, all_events;
  if (selection.one_file) {
    all_samples.emplace(out_dir / "samples.csv", selection.gzip);
    all_events.emplace(out_dir / "events.csv", selection.gzip);
    std::string header = samples_header(channels_of(selection));
    all_samples->line(header);
    header = kEventsHeader;
    all_events->line(header);
  }
  std::string line =
      "trial_id,participant,task,setting,repetition,block,position,status,started_unix_s,ended_unix_s,"
      "abort_reason,updates,loop_count,loop_p50_period_s,loop_p99_period_s,loop_max_period_s,"
      "loop_mean_period_s,loop_overruns,dropped_samples,dropped_events,device_counters";
  index.line(line);
  for (const TrialRow& t : db.trials(study_id)) {
    if (!selected(t, selection)) continue;
    trial_index_line(db, t, line);
    index.line(line);
    if (t.status == TrialStatus::kPlanned) continue;
    if (selection.one_file) {
      write_trial_rows(db, t, *all_samples, *all_events, bad_chunks, selection);
    } else {
      const auto files = export_trial_csv(db, t.id, out_dir, bad_chunks, selection);
      written.insert(written.end(), files.begin(), files.end());
    }
  }
  if (selection.one_file) {
    all_samples->commit();
    all_events->commit();
    written.push_back(all_samples->path());
    written.push_back(all_events->path());
  }
  index.commit();
  written.push_back(index.path());
  written.push_back(write_operator_actions(db, out_dir, selection));
  return written;
}

}  // namespace hapticlab::db
