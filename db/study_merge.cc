#include "db/study_merge.h"

#include <fcntl.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <tuple>
#include <utility>

#include "core/common/sha256.h"
#include "db/chunk_layout.h"
#include "db/chunk_reader.h"
#include "db/schema.h"
#include "db/schema_shape.h"
#include "db/structure_check.h"

namespace hapticlab::db {
namespace fs = std::filesystem;

namespace {

// The oldest input schema read as it is: version 8 differs from 9 only by
// session.site. Older files have other checksums; they are migrated first
// by any command that opens them read-write (the merge writes no input).
constexpr int kOldestInputVersion = 8;

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

// A double as text that reads back to the same bits (for digests).
std::string exact(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string text_or_null(const Statement& s, int c) { return s.is_null(c) ? std::string("\x01") : s.column_text(c); }
std::string real_or_null(const Statement& s, int c) { return s.is_null(c) ? std::string("\x01") : exact(s.column_double(c)); }

struct Participant {
  std::int64_t id = 0;
  std::string code;
  int sessions = 0;
};

struct Setting {
  std::int64_t id = 0;
  std::string name;
  std::string json;
};

struct Input {
  fs::path path;
  std::string site;
  std::size_t index = 0;
  std::unique_ptr<Database> db;
  int version = 0;
  std::string study_name, protocol_json, protocol_sha256, seed, software_version, created_utc;
  std::vector<Participant> participants;  // by id
  std::vector<Setting> settings;          // by id
  bool has_unsited_sessions = false;
  dev_t dev = 0;
  ino_t ino = 0;

  std::string site_expr() const { return version >= 9 ? "site" : "NULL"; }
};

std::optional<std::pair<dev_t, ino_t>> file_id(const fs::path& p) {
  struct stat st {};
  if (::stat(p.c_str(), &st) != 0) return std::nullopt;
  return std::make_pair(st.st_dev, st.st_ino);
}

void check_structure(Input& in) {
  Database& db = *in.db;
  std::vector<std::string> problems;
  {
    Statement s = db.prepare("PRAGMA integrity_check(20)");
    while (s.step())
      if (const std::string line = s.column_text(0); line != "ok") problems.push_back(line);
  }
  std::vector<Finding> found = check_tables(db, in.version);
  if (found.empty()) {
    std::vector<Finding> more = check_foreign_keys(db, std::size_t{20});
    found.insert(found.end(), more.begin(), more.end());
    if (in.version == kSchemaVersion) {
      more = check_value_types(db, std::size_t{20});
      found.insert(found.end(), more.begin(), more.end());
    }
  }
  for (const Finding& f : found) problems.push_back(f.message);
  if (problems.empty()) return;
  std::string list;
  for (std::size_t i = 0; i < problems.size() && i < 5; ++i) list += "\n  " + problems[i];
  throw MergeError(in.path.string() + ": damaged site file, refused (`hapticlab study check --db " + in.path.string() +
                   "` lists everything):" + list);
}

void open_input(Input& in) {
  if (!fs::is_regular_file(in.path))
    throw MergeError(in.path.string() + ": " + (fs::exists(in.path) ? "is not a file" : "does not exist") +
                     "; give the site's study file");
  in.db = std::make_unique<Database>(in.path, Database::Mode::kReadOnly);
  Database& db = *in.db;
  try {
    in.version = check_schema_version(db);
  } catch (const DbError& e) {
    throw MergeError(std::string(e.what()) + "; refused as a site file");
  }
  if (in.version < kOldestInputVersion)
    throw MergeError(in.path.string() + ": schema version " + std::to_string(in.version) +
                     " is older than a merge reads (" + std::to_string(kOldestInputVersion) + ".." +
                     std::to_string(kSchemaVersion) + "); migrate it first with a command that opens it read-write "
                     "(`hapticlab analyze --db " + in.path.string() + " --out DIR`), then merge");
  // One snapshot of the file for the whole merge, even if a station writes.
  db.exec("BEGIN");
  check_structure(in);
  {
    Statement s = db.prepare(
        "SELECT name, protocol_json, protocol_sha256, seed, software_version, created_utc FROM study ORDER BY id");
    int n = 0;
    while (s.step()) {
      if (++n > 1) break;
      in.study_name = s.column_text(0);
      in.protocol_json = s.column_text(1);
      in.protocol_sha256 = s.column_text(2);
      in.seed = s.column_text(3);
      in.software_version = s.column_text(4);
      in.created_utc = s.column_text(5);
    }
    if (n != 1)
      throw MergeError(in.path.string() + ": holds " + (n == 0 ? "no study" : "more than one study") +
                       "; a site file holds the one study made by `hapticlab study create`");
  }
  if (sha256_hex(in.protocol_json) != in.protocol_sha256)
    throw MergeError(in.path.string() + ": the stored protocol text does not match its stored SHA-256 (" +
                     in.protocol_sha256 + "): the file was edited or is damaged; refused");
  {
    Statement s = db.prepare(
        "SELECT p.id, p.code, (SELECT count(*) FROM session WHERE participant_id = p.id) FROM participant p ORDER BY p.id");
    while (s.step())
      in.participants.push_back({s.column_int64(0), s.column_text(1), static_cast<int>(s.column_int64(2))});
  }
  {
    Statement s = db.prepare("SELECT id, name, parameters_json FROM setting ORDER BY id");
    while (s.step()) in.settings.push_back({s.column_int64(0), s.column_text(1), s.column_text(2)});
  }
  // A session still open, or a trial still running: a station is running
  // it, or one was killed and never recovered. Its rows are not final.
  {
    Statement s = db.prepare(
        "SELECT p.code, s.id, (SELECT min(t.id) FROM trial t WHERE t.session_id = s.id AND t.status = 'running') "
        "FROM session s JOIN participant p ON p.id = s.participant_id WHERE s.status = 'open' "
        "UNION ALL SELECT p.code, t.session_id, t.id FROM trial t JOIN participant p ON p.id = t.participant_id "
        "WHERE t.status = 'running' LIMIT 1");
    if (s.step())
      throw MergeError(in.path.string() + ": participant '" + s.column_text(0) + "' has " +
                       (s.is_null(2) ? "session " + std::to_string(s.column_int64(1)) + " still open"
                                     : "trial " + std::to_string(s.column_int64(2)) + " still running") +
                       ": a session runs there, or one was killed and not recovered; let it end, or recover it "
                       "(`hapticlab session run --db " + in.path.string() + " --participant " + s.column_text(0) +
                       "` resumes it), then merge");
  }
  {
    Statement s = db.prepare("SELECT count(*) FROM session WHERE " + in.site_expr() + " IS NULL");
    s.step();
    in.has_unsited_sessions = s.column_int64(0) > 0;
  }
}

// Everything recorded of one participant in one file, without ids or site:
// two files with the same digest hold the same sessions (a file named
// twice under two names, or a site's file beside an earlier merge of it).
std::string participant_digest(Database& db, std::int64_t pid) {
  std::string text;
  std::map<std::int64_t, std::size_t> session_index;
  {
    Statement s = db.prepare(
        "SELECT id, started_unix_s, ended_unix_s, device, clock, status FROM session WHERE participant_id = ?1 "
        "ORDER BY started_unix_s, id");
    s.bind(1, pid);
    while (s.step()) {
      session_index[s.column_int64(0)] = session_index.size();
      text += "S|" + exact(s.column_double(1)) + "|" + real_or_null(s, 2) + "|" + s.column_text(3) + "|" +
              s.column_text(4) + "|" + s.column_text(5) + "\n";
    }
  }
  {
    Statement s = db.prepare(
        "SELECT r.session_id, r.task, r.started_unix_s, r.ended_unix_s, r.duration_s, r.trials, r.cut_short, "
        "r.cut_short_reason FROM training r JOIN session s ON s.id = r.session_id WHERE s.participant_id = ?1 "
        "ORDER BY s.started_unix_s, s.id, r.id");
    s.bind(1, pid);
    while (s.step())
      text += "R|" + std::to_string(session_index[s.column_int64(0)]) + "|" + s.column_text(1) + "|" +
              exact(s.column_double(2)) + "|" + real_or_null(s, 3) + "|" + real_or_null(s, 4) + "|" +
              std::to_string(s.column_int64(5)) + "|" + std::to_string(s.column_int64(6)) + "|" + text_or_null(s, 7) +
              "\n";
  }
  Statement trials = db.prepare(
      "SELECT t.id, t.task, st.name, t.repetition, t.block, t.position, t.status, t.session_id, t.started_unix_s, "
      "t.ended_unix_s, t.abort_reason FROM trial t JOIN setting st ON st.id = t.setting_id WHERE t.participant_id = ?1 "
      "ORDER BY t.id");
  trials.bind(1, pid);
  Statement chunks = db.prepare(
      "SELECT instrument, first_tick, count, t0_s, substr(data, 1, 1), substr(data, 6) FROM sample_chunk "
      "WHERE trial_id = ?1 ORDER BY instrument, first_tick");
  Statement events =
      db.prepare("SELECT t_s, type, instrument, item_index, detail FROM event WHERE trial_id = ?1 ORDER BY id");
  Statement timing = db.prepare(
      "SELECT count, p50_period_s, p99_period_s, max_period_s, mean_period_s, overruns, rejected_periods, "
      "dropped_samples, dropped_events FROM loop_timing WHERE trial_id = ?1");
  Statement counters = db.prepare("SELECT name, value FROM device_counter WHERE trial_id = ?1 ORDER BY name");
  while (trials.step()) {
    const std::int64_t tid = trials.column_int64(0);
    const std::string session =
        trials.is_null(7) ? std::string("-") : std::to_string(session_index[trials.column_int64(7)]);
    text += "T|" + trials.column_text(1) + "|" + trials.column_text(2) + "|" + std::to_string(trials.column_int64(3)) +
            "|" + std::to_string(trials.column_int64(4)) + "|" + std::to_string(trials.column_int64(5)) + "|" +
            trials.column_text(6) + "|" + session + "|" + real_or_null(trials, 8) + "|" + real_or_null(trials, 9) +
            "|" + text_or_null(trials, 10) + "\n";
    chunks.reset();
    chunks.bind(1, tid);
    while (chunks.step()) {
      const std::span<const std::byte> format = chunks.column_blob(4), body = chunks.column_blob(5);
      const std::string_view body_text(reinterpret_cast<const char*>(body.data()), body.size());
      text += "C|" + std::to_string(chunks.column_int64(0)) + "|" + std::to_string(chunks.column_int64(1)) + "|" +
              std::to_string(chunks.column_int64(2)) + "|" + exact(chunks.column_double(3)) + "|" +
              std::to_string(format.empty() ? -1 : std::to_integer<int>(format[0])) + "|" + sha256_hex(body_text) +
              "\n";
    }
    events.reset();
    events.bind(1, tid);
    while (events.step())
      text += "E|" + exact(events.column_double(0)) + "|" + events.column_text(1) + "|" +
              std::to_string(events.column_int64(2)) + "|" + std::to_string(events.column_int64(3)) + "|" +
              text_or_null(events, 4) + "\n";
    timing.reset();
    timing.bind(1, tid);
    while (timing.step()) {
      text += "L";
      for (int c = 0; c < 9; ++c) text += "|" + (c == 0 || c >= 5 ? text_or_null(timing, c) : real_or_null(timing, c));
      text += "\n";
    }
    counters.reset();
    counters.bind(1, tid);
    while (counters.step()) text += "D|" + counters.column_text(0) + "|" + std::to_string(counters.column_int64(1)) + "\n";
  }
  {
    Statement s = db.prepare(
        "SELECT a.session_id, a.unix_s, a.t_s, a.type, a.detail FROM operator_action a JOIN session s "
        "ON s.id = a.session_id WHERE s.participant_id = ?1 ORDER BY a.id");
    s.bind(1, pid);
    while (s.step())
      text += "A|" + std::to_string(session_index[s.column_int64(0)]) + "|" + exact(s.column_double(1)) + "|" +
              real_or_null(s, 2) + "|" + s.column_text(3) + "|" + s.column_text(4) + "\n";
  }
  return sha256_hex(text);
}

// A write to the temporary file failed: a full disk says so plainly.
[[noreturn]] void storage_stop(const fs::path& temp, const fs::path& out, const std::string& cause, bool existed) {
  throw MergeError("study merge stopped: cannot write " + quoted(temp) + ": " + cause + "; the temporary file is "
                   "removed, " + quoted(out) + (existed ? " is as it was" : " was not created") +
                   " and the inputs are untouched; free space (or choose --out on another disk), then run the same "
                   "merge again");
}

std::string sqlite_cause(const DbError& e) {
  const int primary = e.sqlite_code() & 0xff;
  if (primary == SQLITE_FULL) return "the disk is full (" + std::string(e.what()) + ")";
  return e.what();
}

void fsync_path(const fs::path& p, bool directory) {
  const int fd = ::open(p.c_str(), directory ? O_RDONLY | O_DIRECTORY : O_RDONLY);
  if (fd < 0) throw std::runtime_error("cannot open " + quoted(p) + " to sync it: " + std::strerror(errno));
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) throw std::runtime_error("cannot sync " + quoted(p) + ": " + std::strerror(err));
}

void remove_temp(const fs::path& temp) {
  std::error_code ignored;
  for (const char* suffix : {"", "-journal", "-wal", "-shm"}) fs::remove(temp.string() + suffix, ignored);
}

// Temporary files of earlier merges into the same --out whose process is
// gone (killed mid-merge): never renamed, so nobody will; removed.
void remove_stale_temps(const fs::path& dir, const std::string& out_name) {
  const std::string prefix = "." + out_name + ".merge-";
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (!name.starts_with(prefix)) continue;
    const std::size_t end = name.find(".tmp", prefix.size());
    if (end == std::string::npos) continue;
    long pid = 0;
    const auto [ptr, err] = std::from_chars(name.data() + prefix.size(), name.data() + end, pid);
    if (err != std::errc() || ptr != name.data() + end || pid <= 0) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to judge
    fs::remove(e.path(), ec);
  }
}

// Where a trial of the output comes from.
struct TrialSource {
  std::size_t input = 0;
  std::int64_t id = 0;      // in the input
  std::int64_t out_id = 0;  // in the output
  std::int64_t participant_out = 0;
};

struct SessionSource {
  std::size_t input = 0;
  std::int64_t id = 0;
  double started_unix_s = 0.0;
  std::string site;
};

class Builder {
 public:
  Builder(std::vector<Input>& inputs, Database& out) : inputs_(inputs), out_(out) {}

  void study(const Input& in) {
    Statement s = out_.prepare(
        "INSERT INTO study (id, name, protocol_json, protocol_sha256, seed, software_version, created_utc) "
        "VALUES (1, ?1, ?2, ?3, ?4, ?5, ?6)");
    s.bind(1, in.study_name).bind(2, in.protocol_json).bind(3, in.protocol_sha256).bind(4, in.seed);
    s.bind(5, in.software_version).bind(6, in.created_utc).run();
  }

  // Settings by name: the same name must mean the same parameters.
  void settings() {
    std::map<std::string, std::pair<std::int64_t, const Input*>> by_name;
    std::set<std::int64_t> used;
    std::vector<std::pair<const Setting*, const Input*>> pending;
    for (const Input& in : inputs_)
      for (const Setting& st : in.settings) {
        auto it = by_name.find(st.name);
        if (it != by_name.end()) {
          const Setting& first = setting_of(*it->second.second, st.name);
          if (first.json != st.json)
            throw MergeError("setting '" + st.name + "' has other parameters in " + in.path.string() + " than in " +
                             it->second.second->path.string() + ": sites of one study must use the same settings");
          setting_map_[{in.index, st.id}] = it->second.first;
          continue;
        }
        by_name[st.name] = {0, &in};
        pending.emplace_back(&st, &in);
      }
    for (auto& [st, in] : pending)
      if (used.insert(st->id).second) by_name[st->name].first = st->id;
    std::int64_t next = used.empty() ? 1 : *used.rbegin() + 1;
    for (auto& [st, in] : pending)
      if (by_name[st->name].first == 0) by_name[st->name].first = next++;
    // Inserted in id order; every input's row mapped.
    std::vector<std::tuple<std::int64_t, std::string, std::string>> rows;
    for (auto& [st, in] : pending) rows.emplace_back(by_name[st->name].first, st->name, st->json);
    std::sort(rows.begin(), rows.end());
    Statement ins = out_.prepare("INSERT INTO setting (id, study_id, name, parameters_json) VALUES (?1, 1, ?2, ?3)");
    for (const auto& [id, name, json] : rows) {
      ins.reset();
      ins.bind(1, id).bind(2, name).bind(3, json).run();
    }
    for (const Input& in : inputs_)
      for (const Setting& st : in.settings) setting_map_[{in.index, st.id}] = by_name[st.name].first;
  }

  // Participants by code, each taken from `source[code]`.
  void participants(const std::map<std::string, std::size_t>& source) {
    std::map<std::string, std::int64_t> ids;
    std::set<std::int64_t> used;
    std::vector<std::pair<std::string, std::int64_t>> wanted;  // code, id in its first input
    for (const Input& in : inputs_)
      for (const Participant& p : in.participants)
        if (!ids.contains(p.code)) {
          ids[p.code] = 0;
          wanted.emplace_back(p.code, p.id);
        }
    for (auto& [code, id] : wanted)
      if (used.insert(id).second) ids[code] = id;
    std::int64_t next = used.empty() ? 1 : *used.rbegin() + 1;
    for (auto& [code, id] : wanted)
      if (ids[code] == 0) ids[code] = next++;
    std::vector<std::pair<std::int64_t, std::string>> rows;
    for (const auto& [code, id] : ids) rows.emplace_back(id, code);
    std::sort(rows.begin(), rows.end());
    Statement ins = out_.prepare("INSERT INTO participant (id, study_id, code) VALUES (?1, 1, ?2)");
    for (const auto& [id, code] : rows) {
      ins.reset();
      ins.bind(1, id).bind(2, code).run();
      const Input& in = inputs_[source.at(code)];
      for (const Participant& p : in.participants)
        if (p.code == code) chosen_.push_back({in.index, p.id, id});
    }
  }

  // Sessions, training, trials and everything hanging off them.
  void rows(MergeResult& result) {
    collect();
    // Sessions: numbered by start time (then input order), with their site.
    Statement ins_session = out_.prepare(
        "INSERT INTO session (id, participant_id, started_unix_s, ended_unix_s, device, clock, status, site) "
        "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
    for (std::size_t k = 0; k < sessions_.size(); ++k) {
      const SessionSource& src = sessions_[k];
      const std::int64_t out_id = static_cast<std::int64_t>(k + 1);
      session_map_[{src.input, src.id}] = out_id;
      Input& in = inputs_[src.input];
      Statement s = in.db->prepare(
          "SELECT participant_id, started_unix_s, ended_unix_s, device, clock, status FROM session WHERE id = ?1");
      s.bind(1, src.id);
      s.step();
      ins_session.reset();
      ins_session.bind(1, out_id).bind(2, participant_map_.at({src.input, s.column_int64(0)}));
      ins_session.bind(3, s.column_double(1));
      if (s.is_null(2)) ins_session.bind_null(4);
      else ins_session.bind(4, s.column_double(2));
      ins_session.bind(5, s.column_text(3)).bind(6, s.column_text(4)).bind(7, s.column_text(5)).bind(8, src.site);
      ins_session.run();
      ++summary(src.input).sessions;
    }
    result.sessions = static_cast<int>(sessions_.size());
    // Training, by session.
    Statement ins_training = out_.prepare(
        "INSERT INTO training (session_id, task, started_unix_s, ended_unix_s, duration_s, trials, cut_short, "
        "cut_short_reason) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
    for (const SessionSource& src : sessions_) {
      Statement s = inputs_[src.input].db->prepare(
          "SELECT task, started_unix_s, ended_unix_s, duration_s, trials, cut_short, cut_short_reason FROM training "
          "WHERE session_id = ?1 ORDER BY id");
      s.bind(1, src.id);
      while (s.step()) {
        ins_training.reset();
        ins_training.bind(1, session_map_.at({src.input, src.id})).bind(2, s.column_text(0)).bind(3, s.column_double(1));
        copy_real(ins_training, 4, s, 2);
        copy_real(ins_training, 5, s, 3);
        ins_training.bind(6, s.column_int64(4)).bind(7, s.column_int64(5));
        if (s.is_null(6)) ins_training.bind_null(8);
        else ins_training.bind(8, s.column_text(6));
        ins_training.run();
      }
    }
    trials(result);
    operator_actions();
  }

  std::map<std::size_t, SiteSummary*> summaries;

 private:
  struct Chosen {
    std::size_t input;
    std::int64_t id;      // in the input
    std::int64_t out_id;  // in the output
  };

  SiteSummary& summary(std::size_t input) { return *summaries.at(input); }

  static const Setting& setting_of(const Input& in, const std::string& name) {
    for (const Setting& s : in.settings)
      if (s.name == name) return s;
    throw MergeError("internal: setting '" + name + "' vanished from " + in.path.string());
  }

  static void copy_real(Statement& to, int param, const Statement& from, int column) {
    if (from.is_null(column)) to.bind_null(param);
    else to.bind(param, from.column_double(column));
  }

  void collect() {
    for (const Chosen& c : chosen_) {
      participant_map_[{c.input, c.id}] = c.out_id;
      Input& in = inputs_[c.input];
      Statement s = in.db->prepare("SELECT id, started_unix_s, " + in.site_expr() +
                                   " FROM session WHERE participant_id = ?1 ORDER BY id");
      s.bind(1, c.id);
      while (s.step())
        sessions_.push_back({c.input, s.column_int64(0), s.column_double(1), s.is_null(2) ? in.site : s.column_text(2)});
      Statement t = in.db->prepare("SELECT id FROM trial WHERE participant_id = ?1 ORDER BY id");
      t.bind(1, c.id);
      while (t.step()) trials_.push_back({c.input, t.column_int64(0), 0, c.out_id});
    }
    std::stable_sort(sessions_.begin(), sessions_.end(), [](const SessionSource& a, const SessionSource& b) {
      return std::tie(a.started_unix_s, a.input, a.id) < std::tie(b.started_unix_s, b.input, b.id);
    });
    // A trial keeps its id when no trial before it (participant order) took it.
    std::set<std::int64_t> used;
    for (TrialSource& t : trials_)
      if (used.insert(t.id).second) t.out_id = t.id;
    std::int64_t next = used.empty() ? 1 : *used.rbegin() + 1;
    for (TrialSource& t : trials_)
      if (t.out_id == 0) {
        t.out_id = next++;
        ++summary(t.input).trials_renumbered;
      }
    for (const TrialSource& t : trials_) trial_map_[{t.input, t.id}] = t.out_id;
    std::sort(trials_.begin(), trials_.end(), [](const TrialSource& a, const TrialSource& b) { return a.out_id < b.out_id; });
  }

  void trials(MergeResult& result) {
    Statement ins_trial = out_.prepare(
        "INSERT INTO trial (id, participant_id, task, setting_id, repetition, block, position, status, session_id, "
        "started_unix_s, ended_unix_s, abort_reason) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)");
    for (const TrialSource& t : trials_) {
      Input& in = inputs_[t.input];
      Statement s = in.db->prepare(
          "SELECT setting_id, task, repetition, block, position, status, session_id, started_unix_s, ended_unix_s, "
          "abort_reason FROM trial WHERE id = ?1");
      s.bind(1, t.id);
      s.step();
      ins_trial.reset();
      ins_trial.bind(1, t.out_id).bind(2, t.participant_out).bind(3, s.column_text(1));
      ins_trial.bind(4, setting_map_.at({t.input, s.column_int64(0)}));
      ins_trial.bind(5, s.column_int64(2)).bind(6, s.column_int64(3)).bind(7, s.column_int64(4)).bind(8, s.column_text(5));
      if (s.is_null(6)) ins_trial.bind_null(9);
      else ins_trial.bind(9, session_map_.at({t.input, s.column_int64(6)}));
      copy_real(ins_trial, 10, s, 7);
      copy_real(ins_trial, 11, s, 8);
      if (s.is_null(9)) ins_trial.bind_null(12);
      else ins_trial.bind(12, s.column_text(9));
      ins_trial.run();
    }
    result.trials = static_cast<int>(trials_.size());
    Statement ins_chunk = out_.prepare(
        "INSERT INTO sample_chunk (trial_id, instrument, first_tick, count, t0_s, data) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    Statement ins_event = out_.prepare(
        "INSERT INTO event (trial_id, t_s, type, instrument, item_index, detail) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    Statement ins_timing = out_.prepare(
        "INSERT INTO loop_timing (trial_id, count, p50_period_s, p99_period_s, max_period_s, mean_period_s, overruns, "
        "rejected_periods, dropped_samples, dropped_events) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)");
    Statement ins_counter = out_.prepare("INSERT INTO device_counter (trial_id, name, value) VALUES (?1, ?2, ?3)");
    for (const TrialSource& t : trials_) {
      Input& in = inputs_[t.input];
      Database& db = *in.db;
      // The trial's chunk rows laid out, then every chunk verified in full
      // under its own place before it is copied (re-checksummed if the
      // trial got a new id).
      std::vector<BadChunk> bad;
      const ChunkLayout layout = layout_chunks(read_chunk_rows(db, t.id), bad);
      if (!bad.empty())
        throw MergeError(in.path.string() + ": damaged sample chunk: " + describe(bad.front()) +
                         "; the site file is refused (nothing merged); `hapticlab study check --db " +
                         in.path.string() + "` lists every finding");
      Statement blob = db.prepare("SELECT t0_s, data FROM sample_chunk WHERE id = ?1");
      ChunkDecoder decoder;
      for (const auto& rows : layout.instrument)
        for (const ChunkRow& row : rows) {
          blob.reset();
          blob.bind(1, row.id);
          blob.step();
          const ChunkPlace from = row.place();
          ChunkPlace to = from;
          to.trial_id = t.out_id;
          std::vector<std::byte> data;
          try {
            if (to.trial_id == from.trial_id) {
              decoder.check(from, blob.column_blob(1));
              const auto b = blob.column_blob(1);
              data.assign(b.begin(), b.end());
            } else {
              data = move_chunk(from, to, blob.column_blob(1));
            }
          } catch (const ChunkError& e) {
            throw MergeError(in.path.string() + ": damaged sample chunk: " +
                             chunk_name(row.trial_id, row.instrument, row.first_tick, row.count) + ": " + e.what() +
                             "; the site file is refused (nothing merged); `hapticlab study check --db " +
                             in.path.string() + "` lists every finding");
          }
          ins_chunk.reset();
          ins_chunk.bind(1, to.trial_id).bind(2, row.instrument).bind(3, row.first_tick).bind(4, row.count);
          ins_chunk.bind(5, blob.column_double(0)).bind_blob(6, data).run();
          ++result.chunks;
        }
      Statement ev = db.prepare(
          "SELECT t_s, type, instrument, item_index, detail FROM event WHERE trial_id = ?1 ORDER BY id");
      ev.bind(1, t.id);
      while (ev.step()) {
        ins_event.reset();
        ins_event.bind(1, t.out_id).bind(2, ev.column_double(0)).bind(3, ev.column_text(1));
        ins_event.bind(4, ev.column_int64(2)).bind(5, ev.column_int64(3));
        if (ev.is_null(4)) ins_event.bind_null(6);
        else ins_event.bind(6, ev.column_text(4));
        ins_event.run();
      }
      Statement lt = db.prepare(
          "SELECT count, p50_period_s, p99_period_s, max_period_s, mean_period_s, overruns, rejected_periods, "
          "dropped_samples, dropped_events FROM loop_timing WHERE trial_id = ?1");
      lt.bind(1, t.id);
      while (lt.step()) {
        ins_timing.reset();
        ins_timing.bind(1, t.out_id);
        for (int c = 0; c < 9; ++c) {
          if (lt.is_null(c)) ins_timing.bind_null(c + 2);
          else if (c >= 1 && c <= 4) ins_timing.bind(c + 2, lt.column_double(c));
          else ins_timing.bind(c + 2, lt.column_int64(c));
        }
        ins_timing.run();
      }
      Statement dc = db.prepare("SELECT name, value FROM device_counter WHERE trial_id = ?1 ORDER BY name");
      dc.bind(1, t.id);
      while (dc.step()) {
        ins_counter.reset();
        ins_counter.bind(1, t.out_id).bind(2, dc.column_text(0)).bind(3, dc.column_int64(1)).run();
      }
    }
  }

  // The operator's actions of the merged sessions, and those taken while no
  // session ran (a STOP) from every input, each once, in the order taken.
  void operator_actions() {
    struct Action {
      double unix_s;
      std::size_t input;
      std::int64_t id;
      std::optional<std::int64_t> session, trial;
      std::optional<double> t_s;
      std::string type, detail;
    };
    std::vector<Action> all;
    std::set<std::tuple<double, std::string, std::string>> sessionless;
    for (Input& in : inputs_) {
      Statement s = in.db->prepare(
          "SELECT id, session_id, trial_id, unix_s, t_s, type, detail FROM operator_action ORDER BY id");
      while (s.step()) {
        Action a{s.column_double(3), in.index, s.column_int64(0), std::nullopt, std::nullopt, std::nullopt,
                 s.column_text(5), s.column_text(6)};
        if (!s.is_null(4)) a.t_s = s.column_double(4);
        if (!s.is_null(1)) {
          const auto it = session_map_.find({in.index, s.column_int64(1)});
          if (it == session_map_.end()) continue;  // a session of a participant taken from another file
          a.session = it->second;
        } else if (!sessionless.insert({a.unix_s, a.type, a.detail}).second) {
          continue;  // the same STOP from a copy of the same file
        }
        if (!s.is_null(2))
          if (const auto it = trial_map_.find({in.index, s.column_int64(2)}); it != trial_map_.end()) a.trial = it->second;
        all.push_back(std::move(a));
      }
    }
    std::stable_sort(all.begin(), all.end(), [](const Action& a, const Action& b) {
      return std::tie(a.unix_s, a.input, a.id) < std::tie(b.unix_s, b.input, b.id);
    });
    Statement ins = out_.prepare(
        "INSERT INTO operator_action (session_id, trial_id, unix_s, t_s, type, detail) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    for (const Action& a : all) {
      ins.reset();
      if (a.session) ins.bind(1, *a.session);
      else ins.bind_null(1);
      if (a.trial) ins.bind(2, *a.trial);
      else ins.bind_null(2);
      ins.bind(3, a.unix_s);
      if (a.t_s) ins.bind(4, *a.t_s);
      else ins.bind_null(4);
      ins.bind(5, a.type).bind(6, a.detail).run();
    }
  }

  std::vector<Input>& inputs_;
  Database& out_;
  std::vector<Chosen> chosen_;
  std::vector<SessionSource> sessions_;
  std::vector<TrialSource> trials_;
  std::map<std::pair<std::size_t, std::int64_t>, std::int64_t> setting_map_, participant_map_, session_map_, trial_map_;
};

// True when every row of every table is the same in both files.
bool same_content(Database& built, const fs::path& existing) {
  Statement attach = built.prepare("ATTACH DATABASE ?1 AS old");
  attach.bind(1, existing.string()).run();
  bool same = true;
  for (const TableShape& t : schema_tables()) {
    const std::string name = t.name;
    Statement s = built.prepare("SELECT (SELECT count(*) FROM main." + name + ") = (SELECT count(*) FROM old." + name +
                                ") AND NOT EXISTS (SELECT * FROM main." + name + " EXCEPT SELECT * FROM old." + name +
                                ")");
    s.step();
    if (s.column_int64(0) == 0) {
      same = false;
      break;
    }
  }
  built.exec("DETACH DATABASE old");
  return same;
}

// An existing --out: a previous merge of this study, whose sessions the new
// merge all has (by participant, start time and site); anything else is
// refused, naming what would be lost or overwritten.
void check_existing_out(const fs::path& out, const Input& first, Database& built) {
  Database old(out, Database::Mode::kReadOnly);
  int version = 0;
  try {
    version = check_schema_version(old);
  } catch (const DbError& e) {
    throw MergeError("--out " + quoted(out) + " exists and is not a merged study of this HapticLab (" + e.what() +
                     "); a merge replaces only an earlier merge of the same study: give a new --out");
  }
  if (version != kSchemaVersion)
    throw MergeError("--out " + quoted(out) + " exists at schema version " + std::to_string(version) +
                     ", so it is not an earlier merge (merges write version " + std::to_string(kSchemaVersion) +
                     "); give a new --out");
  {
    Statement s = old.prepare("SELECT protocol_sha256 FROM study");
    if (!s.step() || s.column_text(0) != first.protocol_sha256)
      throw MergeError("--out " + quoted(out) + " exists and holds another study (protocol SHA-256 " +
                       (s.is_null(0) ? std::string("none") : s.column_text(0)) + ", the inputs' is " +
                       first.protocol_sha256 + "); give a new --out");
  }
  {
    Statement s = old.prepare("SELECT count(*) FROM session WHERE site IS NULL");
    s.step();
    if (s.column_int64(0) > 0)
      throw MergeError("--out " + quoted(out) + " holds " + std::to_string(s.column_int64(0)) +
                       " session(s) recorded in it (no site): it is a site's own file, not an earlier merge, and a "
                       "merge never overwrites one; give a new --out");
  }
  Statement attach = built.prepare("ATTACH DATABASE ?1 AS old");
  attach.bind(1, out.string()).run();
  std::string lost;
  int n = 0;
  {
    Statement s = built.prepare(
        "SELECT p.code, s.site, count(*) FROM old.session s JOIN old.participant p ON p.id = s.participant_id "
        "WHERE NOT EXISTS (SELECT 1 FROM main.session m JOIN main.participant q ON q.id = m.participant_id "
        "WHERE q.code = p.code AND m.started_unix_s = s.started_unix_s AND m.site = s.site) "
        "GROUP BY p.code, s.site ORDER BY p.code");
    while (s.step()) {
      if (n++ < 5)
        lost += std::string(lost.empty() ? "" : ", ") + "participant '" + s.column_text(0) + "' (" +
                std::to_string(s.column_int64(2)) + " session(s) of site '" + s.column_text(1) + "')";
    }
  }
  built.exec("DETACH DATABASE old");
  if (n > 0)
    throw MergeError("--out " + quoted(out) + " is an earlier merge holding sessions none of the inputs has: " + lost +
                     "; replacing it would lose them: add that site's file to the inputs, or give a new --out");
}

}  // namespace

void check_site_name(const std::string& name, const std::string& what) {
  bool printable = true;
  for (unsigned char c : name)
    if (c < 0x20 || c == 0x7f) printable = false;
  if (name.empty() || name.size() > 64 || !printable || name.front() == ' ' || name.back() == ' ')
    throw MergeError(what + ": site name '" + name + "' must be 1..64 characters, with no control characters and "
                     "no leading or trailing space");
}

MergeResult merge_sites(const MergeOptions& options) {
  if (options.inputs.empty()) throw MergeError("study merge: give at least one site file");
  if (options.out.empty()) throw MergeError("study merge: --out is required");
  if (const fs::path parent = options.out.parent_path(); !parent.empty() && !fs::is_directory(parent))
    throw MergeError("--out " + quoted(options.out) + ": the folder " + quoted(parent) + " does not exist");
  const bool out_exists = fs::exists(options.out);
  const std::optional<std::pair<dev_t, ino_t>> out_id = out_exists ? file_id(options.out) : std::nullopt;
  if (out_exists && !fs::is_regular_file(options.out))
    throw MergeError("--out " + quoted(options.out) + " exists and is not a file");

  MergeResult result;
  std::vector<Input> inputs;
  std::vector<std::pair<dev_t, ino_t>> seen;
  for (const SiteInput& given : options.inputs) {
    SiteSummary summary;
    summary.path = given.path;
    const std::optional<std::pair<dev_t, ino_t>> id = file_id(given.path);
    if (id && out_id && *id == *out_id)
      throw MergeError("--out " + quoted(options.out) + " is the input " + quoted(given.path) +
                       " (the same file): a merge never writes onto one of its own inputs; give a new --out");
    if (id && std::find(seen.begin(), seen.end(), *id) != seen.end()) {
      summary.skipped = true;
      result.notes.push_back(given.path.string() + ": the same file as an earlier input; read once");
      result.sites.push_back(summary);
      continue;
    }
    Input in;
    in.path = given.path;
    in.site = given.site.empty() ? given.path.stem().string() : given.site;
    check_site_name(in.site, given.path.string());
    in.index = inputs.size();
    open_input(in);
    if (id) {
      in.dev = id->first;
      in.ino = id->second;
      seen.push_back(*id);
    }
    bool any_session = false;
    for (const Participant& p : in.participants) any_session = any_session || p.sessions > 0;
    if (in.has_unsited_sessions || !any_session) summary.site = in.site;
    result.sites.push_back(summary);
    inputs.push_back(std::move(in));
  }
  // One study: the same protocol text, by its hash.
  for (const Input& in : inputs)
    if (in.protocol_sha256 != inputs.front().protocol_sha256)
      throw MergeError("different protocols: " + inputs.front().path.string() + " holds study '" +
                       inputs.front().study_name + "' (protocol SHA-256 " + inputs.front().protocol_sha256 + "), " +
                       in.path.string() + " study '" + in.study_name + "' (protocol SHA-256 " + in.protocol_sha256 +
                       "); only site files of one study (the same protocol file) merge");
  // Two site files may not share a site name for their own sessions.
  for (std::size_t a = 0; a < inputs.size(); ++a)
    for (std::size_t b = a + 1; b < inputs.size(); ++b)
      if (inputs[a].has_unsited_sessions && inputs[b].has_unsited_sessions && inputs[a].site == inputs[b].site)
        throw MergeError(inputs[a].path.string() + " and " + inputs[b].path.string() + " would both be site '" +
                         inputs[a].site + "'; name each with --site FILE=NAME");

  // Each participant's sessions from one file; a file identical in a
  // participant's rows to another (the same file twice) counts once.
  std::map<std::string, std::size_t> source;  // code -> input
  std::map<std::string, std::string> digest;
  for (const Input& in : inputs)
    for (const Participant& p : in.participants) {
      if (p.sessions == 0) {
        source.try_emplace(p.code, in.index);
        continue;
      }
      const auto it = source.find(p.code);
      const bool taken = it != source.end() && digest.contains(p.code);
      if (!taken) {
        source[p.code] = in.index;
        digest[p.code] = "";  // computed on demand below
        continue;
      }
      const Input& other = inputs[it->second];
      const Participant* q = nullptr;
      for (const Participant& x : other.participants)
        if (x.code == p.code) q = &x;
      if (digest[p.code].empty()) digest[p.code] = participant_digest(*other.db, q->id);
      if (participant_digest(*in.db, p.id) == digest[p.code]) {
        result.notes.push_back("participant '" + p.code + "': the same " + std::to_string(p.sessions) +
                               " session(s) in " + other.path.string() + " and " + in.path.string() + "; taken once");
        continue;
      }
      throw MergeError("participant '" + p.code + "' has sessions in two files: " + other.path.string() + " (" +
                       std::to_string(q->sessions) + ") and " + in.path.string() + " (" + std::to_string(p.sessions) +
                       "), with different data; a participant's sessions must all come from one site's file");
    }

  // The study row: the earliest created (then the first given), so the
  // order of the inputs does not change it.
  const Input* first = &inputs.front();
  for (const Input& in : inputs)
    if (in.created_utc < first->created_utc) first = &in;

  // Built next to --out (the same file system, so the rename is atomic).
  const fs::path dir = options.out.has_parent_path() ? options.out.parent_path() : fs::path(".");
  const fs::path temp = dir / ("." + options.out.filename().string() + ".merge-" + std::to_string(::getpid()) + ".tmp");
  remove_stale_temps(dir, options.out.filename().string());
  remove_temp(temp);
  try {
    {
      Database out(temp);
      out.exec("PRAGMA journal_mode = DELETE");
      out.exec("PRAGMA synchronous = FULL");
      migrate(out);
      out.exec("PRAGMA foreign_keys = ON");
      Transaction tx(out);
      Builder build(inputs, out);
      std::size_t k = 0;
      for (SiteSummary& s : result.sites)
        if (!s.skipped) build.summaries[k++] = &s;
      build.study(*first);
      build.settings();
      build.participants(source);
      build.rows(result);
      tx.commit();
      for (const auto& [code, input] : source) {
        ++result.participants;
        for (const Participant& p : inputs[input].participants)
          if (p.code == code && p.sessions > 0) ++build.summaries.at(input)->participants;
      }
      {
        Statement s = out.prepare("PRAGMA foreign_key_check");
        if (s.step())
          throw MergeError("internal: the merged file has a broken reference (table " + s.column_text(0) + " row " +
                           std::to_string(s.column_int64(1)) + "); nothing written");
      }
      if (out_exists) {
        check_existing_out(options.out, *first, out);
        if (same_content(out, options.out)) {
          result.unchanged = true;
        }
      }
    }
    if (result.unchanged) {
      remove_temp(temp);
      return result;
    }
    fsync_path(temp, false);
    if (out_exists) {
      // The old file's WAL, if a reader left one, belongs to the old file:
      // folded back into it first, so the renamed file is never read with it.
      Database old(options.out, Database::Mode::kReadWrite);
      old.exec("PRAGMA journal_mode = DELETE");
    }
    if (::rename(temp.c_str(), options.out.c_str()) != 0)
      throw std::runtime_error("cannot rename " + quoted(temp) + " to " + quoted(options.out) + ": " +
                               std::strerror(errno));
    fsync_path(dir, true);
  } catch (const MergeError&) {
    remove_temp(temp);
    throw;
  } catch (const DbError& e) {
    remove_temp(temp);
    const int primary = e.sqlite_code() & 0xff;
    if (primary == SQLITE_FULL || primary == SQLITE_IOERR || primary == SQLITE_CANTOPEN)
      storage_stop(temp, options.out, sqlite_cause(e), out_exists);
    throw MergeError(std::string("study merge stopped: ") + e.what() + "; " + quoted(options.out) +
                     (out_exists ? " is as it was" : " was not created") + " and the inputs are untouched");
  } catch (const std::exception& e) {
    remove_temp(temp);
    storage_stop(temp, options.out, e.what(), out_exists);
  }
  return result;
}

}  // namespace hapticlab::db
