#include "db/study_db.h"

#include <charconv>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <cstring>
#include <stdexcept>

#include <nlohmann/json.hpp>
#include <sqlite3.h>

#include "db/chunk_reader.h"
#include "db/schema.h"
#include "db/session_lock.h"
#include "db/structure_check.h"
#include "db/study_digests.h"
#include "core/common/sha256.h"

namespace hapticlab::db {
namespace {

}  // namespace

std::string iso8601_utc_now() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t secs = std::chrono::system_clock::to_time_t(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms));
  return buf;
}

namespace {

std::optional<double> opt_double(const Statement& s, int c) {
  if (s.is_null(c)) return std::nullopt;
  return s.column_double(c);
}

template <typename T>
void bind_opt(Statement& s, int i, const std::optional<T>& v) {
  if (v) s.bind(i, *v);
  else s.bind_null(i);
}

// Row not found: names the table and id, since "no row" alone says little.
[[noreturn]] void missing(const Database& db, const char* what, std::int64_t id) {
  throw DbError(db.path() + ": no " + what + " with id " + std::to_string(id));
}

constexpr const char* kTrialColumns =
    "t.id, t.participant_id, t.task, t.setting_id, t.repetition, t.block, t.position, t.status, t.session_id, "
    "t.started_unix_s, t.ended_unix_s, t.abort_reason, p.code, s.name "
    "FROM trial t JOIN participant p ON p.id = t.participant_id JOIN setting s ON s.id = t.setting_id ";

TrialRow read_trial(const Database& db, const Statement& s) {
  TrialRow r;
  r.id = s.column_int64(0);
  r.participant_id = s.column_int64(1);
  r.task = s.column_text(2);
  r.setting_id = s.column_int64(3);
  r.repetition = static_cast<int>(s.column_int64(4));
  r.block = static_cast<int>(s.column_int64(5));
  r.position = static_cast<int>(s.column_int64(6));
  try {
    r.status = parse_trial_status(s.column_text(7));
  } catch (const DbError&) {
    // Which file and which trial: the schema's CHECK keeps other values
    // out, so this one came in some other way (a damaged or edited file).
    throw DbError(db.path() + ": trial " + std::to_string(r.id) + ": column trial.status is '" +
                  s.column_text(7).substr(0, 40) + "', but must be one of planned, running, complete, aborted; the "
                  "file is damaged or was edited");
  }
  if (!s.is_null(8)) r.session_id = s.column_int64(8);
  r.started_unix_s = opt_double(s, 9);
  r.ended_unix_s = opt_double(s, 10);
  r.abort_reason = s.column_text(11);
  r.participant_code = s.column_text(12);
  r.setting_name = s.column_text(13);
  return r;
}

// What is wrong with the 100-byte header of a file SQLite calls "not a
// database" (https://sqlite.org/fileformat2.html#the_database_header), or
// "" when nothing there explains it. Read through SQLite's own file handle
// (see below for why never through one of ours).
std::string sqlite_header_problem(Database& db) {
  sqlite3_file* file = nullptr;
  if (sqlite3_file_control(db.raw(), "main", SQLITE_FCNTL_FILE_POINTER, &file) != SQLITE_OK || file == nullptr ||
      file->pMethods == nullptr)
    return "";
  unsigned char h[100] = {};
  const int rc = file->pMethods->xRead(file, h, sizeof h, 0);  // a short file reads as zeros
  if (rc != SQLITE_OK && rc != SQLITE_IOERR_SHORT_READ) return "";
  if (std::memcmp(h, "SQLite format 3", 16) != 0)
    return "not an SQLite database file (it does not start with \"SQLite format 3\")";
  const std::string damaged = "an SQLite file with a damaged header: ";
  const unsigned field = (unsigned{h[16]} << 8) | h[17];
  const unsigned page_size = field == 1 ? 65536 : field;
  if (page_size < 512 || page_size > 65536 || (page_size & (page_size - 1)) != 0)
    return damaged + "its page size (bytes 16-17) is " + std::to_string(field) +
           ", but must be a power of two from 512 to 32768, or 1 for 65536";
  for (int i : {18, 19})
    if (h[i] != 1 && h[i] != 2)
      return damaged + "its file format " + (i == 18 ? "write" : "read") + " version (byte " + std::to_string(i) +
             ") is " + std::to_string(h[i]) + ", but must be 1 (rollback journal) or 2 (WAL)";
  if (page_size - h[20] < 480)
    return damaged + "its reserved space per page (byte 20) is " + std::to_string(h[20]) + ", which leaves " +
           std::to_string(page_size - h[20]) + " usable bytes of a " + std::to_string(page_size) +
           "-byte page, but at least 480 are needed";
  if (h[21] != 64 || h[22] != 32 || h[23] != 32)
    return damaged + "its payload fractions (bytes 21-23) are " + std::to_string(h[21]) + ", " +
           std::to_string(h[22]) + ", " + std::to_string(h[23]) + ", but must be 64, 32, 32";
  return "";
}

}  // namespace

// A file that is not SQLite at all: SQLite itself would only say "file is
// not a database" from whichever statement came first; this says which
// file and what was expected. Asked through the connection, never by
// opening the file ourselves: on Linux, closing any descriptor of the file
// drops every POSIX lock this process holds on it, SQLite's included, and
// another connection (this process's sample writer, another program) would
// then delete the WAL under a live session. An empty or new file passes:
// it becomes a new database.
void refuse_non_sqlite_file(Database& db) {
  try {
    db.prepare("SELECT count(*) FROM sqlite_master").step();
  } catch (const DbError& e) {
    // Anything else (a damaged page) is the integrity check's to report,
    // with SQLite's findings.
    if ((e.sqlite_code() & 0xff) != SQLITE_NOTADB) return;
    const std::string problem = sqlite_header_problem(db);
    throw DbError(db.path() + ": " +
                      (problem.empty() ? "not an SQLite database file (SQLite: file is not a database)" : problem) +
                      "; expected a HapticLab study database, as made by `hapticlab study create`",
                  e.sqlite_code());
  }
}

const char* to_string(TrialStatus status) noexcept {
  switch (status) {
    case TrialStatus::kPlanned: return "planned";
    case TrialStatus::kRunning: return "running";
    case TrialStatus::kComplete: return "complete";
    case TrialStatus::kAborted: return "aborted";
  }
  return "unknown";
}

const char* to_string(SessionStatus status) noexcept {
  switch (status) {
    case SessionStatus::kOpen: return "open";
    case SessionStatus::kClosed: return "closed";
    case SessionStatus::kInterrupted: return "interrupted";
  }
  return "unknown";
}

TrialStatus parse_trial_status(std::string_view name) {
  for (TrialStatus s : {TrialStatus::kPlanned, TrialStatus::kRunning, TrialStatus::kComplete, TrialStatus::kAborted})
    if (name == to_string(s)) return s;
  throw DbError("unknown trial status '" + std::string(name) + "' (planned, running, complete, aborted)");
}

SessionStatus parse_session_status(std::string_view name) {
  for (SessionStatus s : {SessionStatus::kOpen, SessionStatus::kClosed, SessionStatus::kInterrupted})
    if (name == to_string(s)) return s;
  throw DbError("unknown session status '" + std::string(name) + "' (open, closed, interrupted)");
}

double unix_now_s() noexcept {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

StudyDb::StudyDb(const std::filesystem::path& path, const OpenOptions& options)
    : db_(path, options.read_only ? Database::Mode::kReadOnly : Database::Mode::kReadWriteCreate) {
  refuse_non_sqlite_file(db_);
  if (options.mmap_bytes > 0) db_.exec("PRAGMA mmap_size = " + std::to_string(options.mmap_bytes));
  // The check comes before anything else reads the schema, so a damaged
  // file is reported as damaged, with SQLite's findings, and not as the
  // failure of whichever statement happened to trip over it first.
  check_integrity(options.integrity);
  if (!options.read_only) {
    // journal_mode cannot change inside a transaction, so it comes before
    // the migration. In-memory databases answer "memory" and stay so.
    db_.exec("PRAGMA journal_mode = WAL");
    db_.exec("PRAGMA synchronous = NORMAL");
  }
  // Before any query reads a table: each is a table (a view in its place
  // could hold anything, or never end), of the expected columns when current.
  refuse_findings(db_, check_tables(db_, check_schema_version(db_)));
  if (options.read_only) {
    version_found_ = check_schema_version(db_);
    // Version 0 is no HapticLab schema at all (an empty file, another
    // program's database): migrating would not make it a study.
    if (version_found_ == 0)
      throw DbError(db_.path() + ": holds no HapticLab study (no schema: an empty database, or another program's); "
                                 "give a study database made by `hapticlab study create`");
    if (version_found_ != kSchemaVersion)
      throw DbError(db_.path() + ": schema version " + std::to_string(version_found_) + ", expected " +
                    std::to_string(kSchemaVersion) + "; open it once read-write to migrate it");
  } else {
    version_found_ = migrate(db_);
  }
  // With the integrity check, the rows too: every reference points at a
  // row (a trial whose participant is gone would vanish from every join),
  // every value has its column's type (a TEXT 'nan' reads as 0), and the
  // protocol and settings are those the study was created with.
  if (options.integrity != OpenOptions::Integrity::kSkip) {
    std::vector<Finding> findings = check_foreign_keys(db_);
    std::vector<Finding> types = check_value_types(db_);
    findings.insert(findings.end(), types.begin(), types.end());
    std::vector<Finding> edited = check_digests(db_);
    findings.insert(findings.end(), edited.begin(), edited.end());
    refuse_findings(db_, findings);
  }
  if (!options.read_only && options.recover) recover();
}

void StudyDb::check_integrity(OpenOptions::Integrity level) {
  if (level == OpenOptions::Integrity::kSkip) return;
  const char* pragma = level == OpenOptions::Integrity::kFull ? "integrity_check" : "quick_check";
  std::string findings;
  int n = 0;
  try {
    Statement s = db_.prepare(std::string("PRAGMA ") + pragma + "(20)");
    while (s.step()) {
      const std::string line = s.column_text(0);
      if (line == "ok") continue;
      findings += (n++ ? "; " : "") + line;
    }
  } catch (const DbError& e) {
    // A badly damaged file fails the check itself (SQLITE_CORRUPT); a file
    // that cannot be read here (a read-only folder) is not called damaged.
    if (!e.is_damage()) throw DbError(unreadable_reason(db_.path(), e), e.sqlite_code());
    throw DbError(db_.path() + ": " + pragma + " failed, the database file is damaged: " + e.what(),
                  e.sqlite_code());
  }
  if (n > 0)
    throw DbError(db_.path() + ": " + pragma + " found " + std::to_string(n) +
                  " problem(s), the database file is damaged: " + findings);
}

// Only participants with no live session: their lock is free, so whatever
// they left running belongs to a process that is gone. The lock is held
// while their rows change, so a session that starts meanwhile waits.
void StudyDb::recover() {
  std::vector<std::int64_t> participants;
  {
    Statement q = db_.prepare(
        "SELECT participant_id FROM trial WHERE status = 'running' "
        "UNION SELECT participant_id FROM session WHERE status = 'open'");
    while (q.step()) participants.push_back(q.column_int64(0));
  }
  if (participants.empty() || db_.path() == ":memory:") return;
  for (std::int64_t id : participants) {
    std::optional<SessionLock> lock = SessionLock::try_acquire(db_.path(), id, "recovery");
    if (!lock) continue;  // live (or a read-only folder: nothing to recover from here)
    const RecoveryReport r =
        recover_participant(id, lock->stale_owner() ? lock->stale_owner()->abort_reason : std::string());
    recovery_.trials_aborted += r.trials_aborted;
    recovery_.sessions_interrupted += r.sessions_interrupted;
  }
}

RecoveryReport StudyDb::recover_participant(std::int64_t participant_id, std::string_view reason) {
  RecoveryReport report;
  Transaction tx(db_);
  Statement trials = db_.prepare(
      "UPDATE trial SET status = 'aborted', abort_reason = ?1 WHERE status = 'running' AND participant_id = ?2");
  trials.bind(1, reason.empty() ? std::string_view(kInterruptedReason) : reason).bind(2, participant_id).run();
  report.trials_aborted = db_.changes();
  Statement sessions =
      db_.prepare("UPDATE session SET status = 'interrupted' WHERE status = 'open' AND participant_id = ?1");
  sessions.bind(1, participant_id).run();
  report.sessions_interrupted = db_.changes();
  tx.commit();
  return report;
}

// --- studies, participants, settings

std::int64_t StudyDb::add_study(const StudyInfo& info) {
  Statement s = db_.prepare(
      "INSERT INTO study (name, protocol_json, protocol_sha256, seed, software_version, created_utc) "
      "VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  // The seed is a uint64; SQLite integers are signed, so it is kept as its
  // decimal text (readable in any SQLite shell, exact).
  s.bind(1, info.name).bind(2, info.protocol_json).bind(3, sha256_hex(info.protocol_json))
      .bind(4, std::to_string(info.seed)).bind(5, info.software_version).bind(6, iso8601_utc_now());
  s.run();
  return db_.last_insert_rowid();
}

StudyRow StudyDb::study(std::int64_t id) {
  for (StudyRow& r : studies())
    if (r.id == id) return r;
  missing(db_, "study", id);
}

std::vector<StudyRow> StudyDb::studies() {
  Statement s = db_.prepare(
      "SELECT id, name, protocol_json, protocol_sha256, seed, software_version, created_utc FROM study ORDER BY id");
  std::vector<StudyRow> out;
  while (s.step()) {
    StudyRow r;
    r.id = s.column_int64(0);
    r.name = s.column_text(1);
    r.protocol_json = s.column_text(2);
    r.protocol_sha256 = s.column_text(3);
    // Stored as text (a u64 does not fit SQLite's integer): read back
    // strictly, naming the row, since std::stoull would say only "stoull"
    // and would take "-1" or "12abc".
    const std::string seed = s.column_text(4);
    const auto [end, ec] = std::from_chars(seed.data(), seed.data() + seed.size(), r.seed, 10);
    if (seed.empty() || ec != std::errc{} || end != seed.data() + seed.size())
      throw DbError(db_.path() + ": study " + std::to_string(r.id) + ": column study.seed is '" + seed.substr(0, 40) +
                    "', but must be a whole number from 0 to 18446744073709551615; the file is damaged or was edited");
    r.software_version = s.column_text(5);
    r.created_utc = s.column_text(6);
    // The sessions' schedule, tasks and design come from this text.
    if (const std::string found = sha256_hex(r.protocol_json); found != r.protocol_sha256)
      throw DbError(db_.path() + ": " + edited_protocol_message(r.id, r.protocol_sha256, found));
    out.push_back(std::move(r));
  }
  return out;
}

std::int64_t StudyDb::add_participant(std::int64_t study_id, std::string_view code) {
  Statement s = db_.prepare("INSERT INTO participant (study_id, code) VALUES (?1, ?2)");
  s.bind(1, study_id).bind(2, code).run();
  return db_.last_insert_rowid();
}

std::optional<std::int64_t> StudyDb::find_participant(std::int64_t study_id, std::string_view code) {
  Statement s = db_.prepare("SELECT id FROM participant WHERE study_id = ?1 AND code = ?2");
  s.bind(1, study_id).bind(2, code);
  if (!s.step()) return std::nullopt;
  return s.column_int64(0);
}

std::int64_t StudyDb::add_setting(std::int64_t study_id, const NamedSettings& settings) {
  return add_setting_json(study_id, settings.name, settings_to_json(settings).dump(2));
}

std::int64_t StudyDb::add_setting_json(std::int64_t study_id, std::string_view name,
                                       std::string_view parameters_json) {
  Statement s = db_.prepare(
      "INSERT INTO setting (study_id, name, parameters_json, parameters_sha256) VALUES (?1, ?2, ?3, ?4)");
  s.bind(1, study_id).bind(2, name).bind(3, parameters_json).bind(4, sha256_hex(parameters_json)).run();
  return db_.last_insert_rowid();
}

std::string StudyDb::setting_json(std::int64_t setting_id) {
  Statement s = db_.prepare("SELECT parameters_json, parameters_sha256, name FROM setting WHERE id = ?1");
  s.bind(1, setting_id);
  if (!s.step()) missing(db_, "setting", setting_id);
  std::string json = s.column_text(0);
  // A session configures its engine from this text, and analysis reads its
  // fields: an edit would change what the participants after it feel, and
  // the comparison, without a word.
  if (const std::string found = sha256_hex(json); found != s.column_text(1))
    throw DbError(db_.path() + ": " + edited_setting_message(setting_id, s.column_text(2), s.column_text(1), found));
  return json;
}

std::vector<std::pair<std::int64_t, std::string>> StudyDb::settings(std::int64_t study_id) {
  Statement s = db_.prepare("SELECT id, name FROM setting WHERE study_id = ?1 ORDER BY id");
  s.bind(1, study_id);
  std::vector<std::pair<std::int64_t, std::string>> out;
  while (s.step()) out.emplace_back(s.column_int64(0), s.column_text(1));
  return out;
}

NamedSettings StudyDb::setting(std::int64_t setting_id) {
  return settings_from_json_text(setting_json(setting_id),
                                 db_.path() + ": setting " + std::to_string(setting_id));
}

// --- sessions and training

std::int64_t StudyDb::begin_session(std::int64_t participant_id, std::string_view device, std::string_view clock,
                                    std::optional<double> rate_Hz) {
  Statement s = db_.prepare(
      "INSERT INTO session (participant_id, started_unix_s, device, clock, status, rate_Hz) "
      "VALUES (?1, ?2, ?3, ?4, 'open', ?5)");
  s.bind(1, participant_id).bind(2, unix_now_s()).bind(3, device).bind(4, clock);
  if (rate_Hz) s.bind(5, *rate_Hz);
  else s.bind_null(5);
  s.run();
  return db_.last_insert_rowid();
}

void StudyDb::set_session_participant_model(std::int64_t session_id, std::string_view model) {
  Statement s = db_.prepare("UPDATE session SET participant_model = ?2 WHERE id = ?1");
  s.bind(1, session_id).bind(2, model).run();
  if (db_.changes() == 0) missing(db_, "session", session_id);
}

void StudyDb::end_session(std::int64_t session_id, SessionStatus status) {
  Statement s = db_.prepare("UPDATE session SET status = ?2, ended_unix_s = ?3 WHERE id = ?1");
  s.bind(1, session_id).bind(2, to_string(status)).bind(3, unix_now_s()).run();
  if (db_.changes() == 0) missing(db_, "session", session_id);
}

namespace {

constexpr const char* kSessionColumns =
    "id, participant_id, started_unix_s, ended_unix_s, device, clock, status, site, rate_Hz, participant_model";

SessionRow session_row(const std::string& path, Statement& s) {
  SessionRow r;
  r.id = s.column_int64(0);
  r.participant_id = s.column_int64(1);
  r.started_unix_s = s.column_double(2);
  r.ended_unix_s = opt_double(s, 3);
  r.device = s.column_text(4);
  r.clock = s.column_text(5);
  if (!s.is_null(7)) r.site = s.column_text(7);
  r.rate_Hz = opt_double(s, 8);
  if (!s.is_null(9)) r.participant_model = s.column_text(9);
  try {
    r.status = parse_session_status(s.column_text(6));
  } catch (const DbError&) {
    throw DbError(path + ": session " + std::to_string(r.id) + ": column session.status is '" +
                  s.column_text(6).substr(0, 40) + "', but must be one of open, closed, interrupted; the file is "
                  "damaged or was edited");
  }
  return r;
}

}  // namespace

SessionRow StudyDb::session(std::int64_t id) {
  Statement s = db_.prepare(std::string("SELECT ") + kSessionColumns + " FROM session WHERE id = ?1");
  s.bind(1, id);
  if (!s.step()) missing(db_, "session", id);
  return session_row(db_.path(), s);
}

std::vector<SessionRow> StudyDb::sessions() {
  Statement s = db_.prepare(std::string("SELECT ") + kSessionColumns + " FROM session ORDER BY id");
  std::vector<SessionRow> out;
  while (s.step()) out.push_back(session_row(db_.path(), s));
  return out;
}

std::int64_t StudyDb::add_training(const TrainingRow& t) {
  Statement s = db_.prepare(
      "INSERT INTO training (session_id, task, started_unix_s, ended_unix_s, duration_s, trials, cut_short, "
      "cut_short_reason) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
  s.bind(1, t.session_id).bind(2, t.task).bind(3, t.started_unix_s);
  bind_opt(s, 4, t.ended_unix_s);
  bind_opt(s, 5, t.duration_s);
  s.bind(6, std::int64_t{t.trials}).bind(7, std::int64_t{t.cut_short});
  if (t.cut_short_reason.empty()) s.bind_null(8); else s.bind(8, t.cut_short_reason);
  s.run();
  return db_.last_insert_rowid();
}

std::vector<TrainingRow> StudyDb::training(std::int64_t session_id) {
  Statement s = db_.prepare(
      "SELECT id, task, started_unix_s, ended_unix_s, duration_s, trials, cut_short, cut_short_reason FROM training "
      "WHERE session_id = ?1 ORDER BY id");
  s.bind(1, session_id);
  std::vector<TrainingRow> out;
  while (s.step()) {
    TrainingRow r;
    r.id = s.column_int64(0);
    r.session_id = session_id;
    r.task = s.column_text(1);
    r.started_unix_s = s.column_double(2);
    r.ended_unix_s = opt_double(s, 3);
    r.duration_s = opt_double(s, 4);
    r.trials = static_cast<int>(s.column_int64(5));
    r.cut_short = static_cast<int>(s.column_int64(6));
    r.cut_short_reason = s.column_text(7);
    out.push_back(std::move(r));
  }
  return out;
}

// --- trials

std::int64_t StudyDb::add_trial(const TrialPlan& p) {
  Statement s = db_.prepare(
      "INSERT INTO trial (participant_id, task, setting_id, repetition, block, position, status) "
      "VALUES (?1, ?2, ?3, ?4, ?5, ?6, 'planned')");
  s.bind(1, p.participant_id).bind(2, p.task).bind(3, p.setting_id).bind(4, std::int64_t{p.repetition})
      .bind(5, std::int64_t{p.block}).bind(6, std::int64_t{p.position}).run();
  return db_.last_insert_rowid();
}

void StudyDb::start_trial(std::int64_t trial_id, std::int64_t session_id) {
  Statement s = db_.prepare(
      "UPDATE trial SET status = 'running', session_id = ?2, started_unix_s = ?3 "
      "WHERE id = ?1 AND status = 'planned'");
  s.bind(1, trial_id).bind(2, session_id).bind(3, unix_now_s()).run();
  if (db_.changes() == 0)
    throw DbError(db_.path() + ": start_trial: trial " + std::to_string(trial_id) + " is " +
                  to_string(trial(trial_id).status) + ", only a planned trial can start");
}

void StudyDb::end_trial(std::int64_t trial_id, TrialStatus status, std::string_view abort_reason) {
  if (status != TrialStatus::kComplete && status != TrialStatus::kAborted)
    throw DbError(db_.path() + ": end_trial: trial " + std::to_string(trial_id) + " cannot end as '" +
                  to_string(status) + "' (complete or aborted)");
  Statement s = db_.prepare(
      "UPDATE trial SET status = ?2, ended_unix_s = ?3, abort_reason = ?4 WHERE id = ?1 AND status = 'running'");
  s.bind(1, trial_id).bind(2, to_string(status)).bind(3, unix_now_s());
  if (status == TrialStatus::kAborted) s.bind(4, abort_reason);
  else s.bind_null(4);
  s.run();
  if (db_.changes() == 0)
    throw DbError(db_.path() + ": end_trial: trial " + std::to_string(trial_id) + " is " +
                  to_string(trial(trial_id).status) + ", only a running trial can end");
}

TrialRow StudyDb::trial(std::int64_t id) {
  Statement s = db_.prepare(std::string("SELECT ") + kTrialColumns + "WHERE t.id = ?1");
  s.bind(1, id);
  if (!s.step()) missing(db_, "trial", id);
  return read_trial(db_, s);
}

std::vector<TrialRow> StudyDb::trials(std::optional<std::int64_t> study_id) {
  Statement s = db_.prepare(std::string("SELECT ") + kTrialColumns +
                            "WHERE ?1 IS NULL OR p.study_id = ?1 ORDER BY p.study_id, p.code, t.position, t.id");
  bind_opt(s, 1, study_id);
  std::vector<TrialRow> out;
  while (s.step()) out.push_back(read_trial(db_, s));
  return out;
}

std::optional<std::int64_t> StudyDb::next_planned_trial(std::int64_t participant_id) {
  Statement s = db_.prepare(
      "SELECT id FROM trial WHERE participant_id = ?1 AND status = 'planned' ORDER BY position, id LIMIT 1");
  s.bind(1, participant_id);
  if (!s.step()) return std::nullopt;
  return s.column_int64(0);
}

std::int64_t StudyDb::requeue_trial(std::int64_t trial_id) {
  const TrialRow t = trial(trial_id);
  if (t.status != TrialStatus::kAborted)
    throw DbError(db_.path() + ": requeue_trial: trial " + std::to_string(trial_id) + " is " + to_string(t.status) +
                  ", only an aborted trial can be re-queued");
  // One live (not aborted) trial per position: a second re-queue of the
  // same slot would run it twice.
  Statement live = db_.prepare(
      "SELECT id, status FROM trial WHERE participant_id = ?1 AND position = ?2 AND status <> 'aborted'");
  live.bind(1, t.participant_id).bind(2, std::int64_t{t.position});
  if (live.step())
    throw DbError(db_.path() + ": requeue_trial: position " + std::to_string(t.position) + " of participant " +
                  t.participant_code + " already holds trial " + std::to_string(live.column_int64(0)) + " (" +
                  live.column_text(1) + "); trial " + std::to_string(trial_id) + " is not re-queued twice");
  return add_trial(t);
}

}  // namespace hapticlab::db
