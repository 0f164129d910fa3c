// StudyDb's records of a trial's run (study_db.h): task events, loop
// timing, device counters, the operator's actions and the sample chunks.
#include <string>
#include <utility>
#include <vector>

#include "db/chunk_reader.h"
#include "db/study_db.h"

namespace hapticlab::db {

// --- events and loop timing

void StudyDb::add_event(const EventRow& e) {
  Statement s = db_.prepare(
      "INSERT INTO event (trial_id, t_s, type, instrument, item_index, detail) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  s.bind(1, e.trial_id).bind(2, e.t_s).bind(3, e.type).bind(4, std::int64_t{e.instrument}).bind(5, e.item_index);
  if (e.detail.empty()) s.bind_null(6);
  else s.bind(6, e.detail);
  s.run();
}

std::vector<EventRow> StudyDb::events(std::int64_t trial_id) {
  Statement s = db_.prepare(
      "SELECT t_s, type, instrument, item_index, detail FROM event WHERE trial_id = ?1 ORDER BY t_s, id");
  s.bind(1, trial_id);
  std::vector<EventRow> out;
  while (s.step()) {
    EventRow e;
    e.trial_id = trial_id;
    e.t_s = s.column_double(0);
    e.type = s.column_text(1);
    e.instrument = static_cast<int>(s.column_int64(2));
    e.item_index = s.column_int64(3);
    e.detail = s.column_text(4);
    out.push_back(std::move(e));
  }
  return out;
}

void StudyDb::set_loop_timing(std::int64_t trial_id, const LoopTimingSummary& t, std::uint64_t dropped_samples,
                              std::uint64_t dropped_events) {
  Statement s = db_.prepare(
      "INSERT OR REPLACE INTO loop_timing (trial_id, count, p50_period_s, p99_period_s, max_period_s, "
      "mean_period_s, overruns, rejected_periods, dropped_samples, dropped_events) "
      "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)");
  // Counts fit in int64 for any run shorter than 290 million years at 1 kHz.
  s.bind(1, trial_id).bind(2, static_cast<std::int64_t>(t.count)).bind(3, t.p50_period_s)
      .bind(4, t.p99_period_s).bind(5, t.max_period_s).bind(6, t.mean_period_s)
      .bind(7, static_cast<std::int64_t>(t.overruns)).bind(8, static_cast<std::int64_t>(t.rejected))
      .bind(9, static_cast<std::int64_t>(dropped_samples)).bind(10, static_cast<std::int64_t>(dropped_events));
  s.run();
}

void StudyDb::set_device_counters(std::int64_t trial_id,
                                  const std::vector<std::pair<std::string, std::uint64_t>>& counters) {
  Statement clear = db_.prepare("DELETE FROM device_counter WHERE trial_id = ?1");
  clear.bind(1, trial_id);
  clear.run();
  Statement s = db_.prepare("INSERT OR REPLACE INTO device_counter (trial_id, name, value) VALUES (?1, ?2, ?3)");
  for (const auto& [name, value] : counters) {
    s.reset();
    s.bind(1, trial_id).bind(2, name).bind(3, static_cast<std::int64_t>(value));
    s.run();
  }
}

std::vector<std::pair<std::string, std::uint64_t>> StudyDb::device_counters(std::int64_t trial_id) {
  Statement s = db_.prepare("SELECT name, value FROM device_counter WHERE trial_id = ?1 ORDER BY name");
  s.bind(1, trial_id);
  std::vector<std::pair<std::string, std::uint64_t>> out;
  while (s.step()) out.emplace_back(s.column_text(0), static_cast<std::uint64_t>(s.column_int64(1)));
  return out;
}

std::int64_t StudyDb::add_operator_action(const OperatorActionRow& a) {
  Statement s = db_.prepare(
      "INSERT INTO operator_action (session_id, trial_id, unix_s, t_s, type, detail) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  if (a.session_id) s.bind(1, *a.session_id);
  else s.bind_null(1);
  if (a.trial_id) s.bind(2, *a.trial_id);
  else s.bind_null(2);
  s.bind(3, a.unix_s);
  if (a.t_s) s.bind(4, *a.t_s);
  else s.bind_null(4);
  s.bind(5, a.type).bind(6, a.detail);
  s.run();
  return db_.last_insert_rowid();
}

std::vector<OperatorActionRow> StudyDb::operator_actions() {
  Statement s = db_.prepare(
      "SELECT a.id, a.session_id, a.trial_id, a.unix_s, a.t_s, a.type, a.detail, p.code FROM operator_action a "
      "LEFT JOIN session se ON se.id = a.session_id LEFT JOIN participant p ON p.id = se.participant_id "
      "ORDER BY a.id");
  std::vector<OperatorActionRow> out;
  while (s.step()) {
    OperatorActionRow a;
    a.id = s.column_int64(0);
    if (!s.is_null(1)) a.session_id = s.column_int64(1);
    if (!s.is_null(2)) a.trial_id = s.column_int64(2);
    a.unix_s = s.column_double(3);
    if (!s.is_null(4)) a.t_s = s.column_double(4);
    a.type = s.column_text(5);
    a.detail = s.column_text(6);
    if (!s.is_null(7)) a.participant_code = s.column_text(7);
    out.push_back(std::move(a));
  }
  return out;
}

std::optional<LoopTimingRow> StudyDb::loop_timing(std::int64_t trial_id) {
  Statement s = db_.prepare(
      "SELECT count, p50_period_s, p99_period_s, max_period_s, mean_period_s, overruns, rejected_periods, "
      "dropped_samples, dropped_events FROM loop_timing WHERE trial_id = ?1");
  s.bind(1, trial_id);
  if (!s.step()) return std::nullopt;
  LoopTimingRow r;
  if (!s.is_null(0)) {
    LoopTimingSummary t;
    t.count = static_cast<std::uint64_t>(s.column_int64(0));
    t.p50_period_s = s.column_double(1);
    t.p99_period_s = s.column_double(2);
    t.max_period_s = s.column_double(3);
    t.mean_period_s = s.column_double(4);
    t.overruns = static_cast<std::uint64_t>(s.column_int64(5));
    t.rejected = static_cast<std::uint64_t>(s.column_int64(6));
    r.timing = t;
  }
  r.dropped_samples = static_cast<std::uint64_t>(s.column_int64(7));
  r.dropped_events = static_cast<std::uint64_t>(s.column_int64(8));
  return r;
}

// --- samples

std::int64_t StudyDb::insert_chunk(std::int64_t trial_id, int instrument, std::span<const StoredSample> samples) {
  const std::vector<std::byte> blob = encode_chunk(trial_id, instrument, samples);
  Statement s = db_.prepare(
      "INSERT INTO sample_chunk (trial_id, instrument, first_tick, count, t0_s, data) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  s.bind(1, trial_id).bind(2, std::int64_t{instrument}).bind(3, static_cast<std::int64_t>(samples[0].tick))
      .bind(4, static_cast<std::int64_t>(samples.size())).bind(5, samples[0].t_s).bind_blob(6, blob);
  s.run();
  return db_.last_insert_rowid();
}

void StudyDb::update_chunk(std::int64_t chunk_id, std::int64_t trial_id, int instrument,
                           std::span<const StoredSample> samples) {
  const std::vector<std::byte> blob = encode_chunk(trial_id, instrument, samples);
  Statement s = db_.prepare(
      "UPDATE sample_chunk SET count = ?2, data = ?3 WHERE id = ?1 AND first_tick = ?4 AND trial_id = ?5 AND "
      "instrument = ?6");
  s.bind(1, chunk_id).bind(2, static_cast<std::int64_t>(samples.size())).bind_blob(3, blob)
      .bind(4, static_cast<std::int64_t>(samples[0].tick)).bind(5, trial_id).bind(6, std::int64_t{instrument});
  s.run();
  if (db_.changes() == 0)
    throw DbError(db_.path() + ": no sample_chunk of that trial and instrument starting at that tick with id " +
                  std::to_string(chunk_id));
}

std::vector<StoredSample> StudyDb::samples(std::int64_t trial_id, int instrument) {
  std::vector<StoredSample> out;
  std::vector<BadChunk> bad;
  read_samples(db_, trial_id, instrument, out, bad);
  if (!bad.empty())
    throw DbError(db_.path() + ": " + describe(bad.front()) +
                  (bad.size() > 1 ? " (and " + std::to_string(bad.size() - 1) + " more damaged chunks)" : ""));
  return out;
}

std::uint64_t StudyDb::sample_count(std::int64_t trial_id, int instrument) {
  Statement s = db_.prepare("SELECT coalesce(sum(count), 0) FROM sample_chunk WHERE trial_id = ?1 AND instrument = ?2");
  s.bind(1, trial_id).bind(2, std::int64_t{instrument});
  s.step();
  return static_cast<std::uint64_t>(s.column_int64(0));
}

}  // namespace hapticlab::db
