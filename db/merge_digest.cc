// The digest of one participant's rows in one site file (merge_input.h):
// sessions, training, trials with their chunks, events, timing and device
// counts, and operator actions, as text without ids or site, hashed.
#include <charconv>
#include <map>
#include <span>
#include <string_view>

#include "core/common/sha256.h"
#include "db/merge_input.h"

namespace hapticlab::db::merge {

namespace {

// A double as text that reads back to the same bits (for digests).
std::string exact(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string text_or_null(const Statement& s, int c) { return s.is_null(c) ? std::string("\x01") : s.column_text(c); }
std::string real_or_null(const Statement& s, int c) { return s.is_null(c) ? std::string("\x01") : exact(s.column_double(c)); }

// A session's place among the participant's sessions (by start time), which
// stands for its id in the digest.
using SessionIndex = std::map<std::int64_t, std::size_t>;

// `conditions`: Input::session_conditions_expr() (NULL, NULL in a site file
// of version 8 or 9, as a merge copies them).
SessionIndex add_sessions(Database& db, std::int64_t pid, const std::string& conditions, std::string& text) {
  SessionIndex session_index;
  Statement s = db.prepare("SELECT id, started_unix_s, ended_unix_s, device, clock, status, " + conditions +
                           " FROM session WHERE participant_id = ?1 ORDER BY started_unix_s, id");
  s.bind(1, pid);
  while (s.step()) {
    session_index[s.column_int64(0)] = session_index.size();
    text += "S|" + exact(s.column_double(1)) + "|" + real_or_null(s, 2) + "|" + s.column_text(3) + "|" +
            s.column_text(4) + "|" + s.column_text(5) + "|" + real_or_null(s, 6) + "|" +
            text_or_null(s, 7) + "\n";
  }
  return session_index;
}

void add_training(Database& db, std::int64_t pid, SessionIndex& session_index, std::string& text) {
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

// What hangs off one trial: its chunks (by their bodies' hashes), events,
// loop timing and device counts.
struct TrialRowsQueries {
  Statement chunks, events, timing, counters;

  explicit TrialRowsQueries(Database& db)
      : chunks(db.prepare("SELECT instrument, first_tick, count, t0_s, substr(data, 1, 1), substr(data, 6) FROM "
                          "sample_chunk WHERE trial_id = ?1 ORDER BY instrument, first_tick")),
        events(db.prepare("SELECT t_s, type, instrument, item_index, detail FROM event WHERE trial_id = ?1 ORDER BY id")),
        timing(db.prepare("SELECT count, p50_period_s, p99_period_s, max_period_s, mean_period_s, overruns, "
                          "rejected_periods, dropped_samples, dropped_events FROM loop_timing WHERE trial_id = ?1")),
        counters(db.prepare("SELECT name, value FROM device_counter WHERE trial_id = ?1 ORDER BY name")) {}

  void add(std::int64_t tid, std::string& text) {
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
      for (int c = 0; c < 9; ++c) {
        text += '|';  // on its own: GCC 12 -O3 warns, wrongly, about "|" + std::string
        text += c == 0 || c >= 5 ? text_or_null(timing, c) : real_or_null(timing, c);
      }
      text += "\n";
    }
    counters.reset();
    counters.bind(1, tid);
    while (counters.step()) text += "D|" + counters.column_text(0) + "|" + std::to_string(counters.column_int64(1)) + "\n";
  }
};

void add_trials(Database& db, std::int64_t pid, SessionIndex& session_index, std::string& text) {
  Statement trials = db.prepare(
      "SELECT t.id, t.task, st.name, t.repetition, t.block, t.position, t.status, t.session_id, t.started_unix_s, "
      "t.ended_unix_s, t.abort_reason FROM trial t JOIN setting st ON st.id = t.setting_id WHERE t.participant_id = ?1 "
      "ORDER BY t.id");
  trials.bind(1, pid);
  TrialRowsQueries rows(db);
  while (trials.step()) {
    const std::int64_t tid = trials.column_int64(0);
    const std::string session =
        trials.is_null(7) ? std::string("-") : std::to_string(session_index[trials.column_int64(7)]);
    text += "T|" + trials.column_text(1) + "|" + trials.column_text(2) + "|" + std::to_string(trials.column_int64(3)) +
            "|" + std::to_string(trials.column_int64(4)) + "|" + std::to_string(trials.column_int64(5)) + "|" +
            trials.column_text(6) + "|" + session + "|" + real_or_null(trials, 8) + "|" + real_or_null(trials, 9) +
            "|" + text_or_null(trials, 10) + "\n";
    rows.add(tid, text);
  }
}

void add_operator_actions(Database& db, std::int64_t pid, SessionIndex& session_index, std::string& text) {
  Statement s = db.prepare(
      "SELECT a.session_id, a.unix_s, a.t_s, a.type, a.detail FROM operator_action a JOIN session s "
      "ON s.id = a.session_id WHERE s.participant_id = ?1 ORDER BY a.id");
  s.bind(1, pid);
  while (s.step())
    text += "A|" + std::to_string(session_index[s.column_int64(0)]) + "|" + exact(s.column_double(1)) + "|" +
            real_or_null(s, 2) + "|" + s.column_text(3) + "|" + s.column_text(4) + "\n";
}

}  // namespace

std::string participant_digest(const Input& in, std::int64_t pid) {
  Database& db = *in.db;
  std::string text;
  SessionIndex session_index = add_sessions(db, pid, in.session_conditions_expr(), text);
  add_training(db, pid, session_index, text);
  add_trials(db, pid, session_index, text);
  add_operator_actions(db, pid, session_index, text);
  return sha256_hex(text);
}

}  // namespace hapticlab::db::merge
