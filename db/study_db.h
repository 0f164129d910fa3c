#pragma once
// StudyDb: typed access to a study database (tables in db/README.md).
//
// Opening a file, in this order:
//   0. A file that is not SQLite at all is refused, naming it. Nothing here
//      opens the file outside SQLite (see refuse_non_sqlite_file).
//   1. PRAGMA integrity_check (or quick_check); a damaged file is refused
//      with SQLite's findings.
//   2. WAL journal, synchronous = NORMAL: a committed transaction survives
//      a killed process (not necessarily a power cut in its last instant),
//      and readers never block the writer.
//   3. Migration to the current schema version (schema.h), all or nothing.
//   4. Recovery of dead sessions only: a trial left 'running' by a session
//      whose process is gone (crashed, killed) becomes 'aborted' with reason
//      kInterruptedReason, its samples kept; a session left 'open' becomes
//      'interrupted'. "Gone" is decided by the participant's SessionLock
//      (session_lock.h), never by the rows, so opening the file while other
//      sessions run (a second station, a monitor) leaves their trials alone.
//
// Times: *_unix_s are wall-clock seconds since 1970-01-01 UTC
// (std::chrono::system_clock); t_s of samples and events is the haptic
// loop's clock [s] from the start of the trial's loop.
//
// Threads: one StudyDb per thread. SampleWriter opens its own.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/loop/loop_timing.h"
#include "core/settings/settings_json.h"
#include "db/sample_codec.h"
#include "db/sqlite_handle.h"

namespace hapticlab::db {

enum class TrialStatus : std::uint8_t { kPlanned, kRunning, kComplete, kAborted };
enum class SessionStatus : std::uint8_t { kOpen, kClosed, kInterrupted };
// The names stored in the database: "planned", "running", ...
const char* to_string(TrialStatus status) noexcept;
const char* to_string(SessionStatus status) noexcept;
// Throws DbError naming the value for an unknown name.
TrialStatus parse_trial_status(std::string_view name);
SessionStatus parse_session_status(std::string_view name);

inline constexpr const char* kInterruptedReason = "interrupted (runner crashed or was killed)";

struct StudyInfo {
  std::string name;
  std::string protocol_json;  // the protocol file's text, byte for byte
  std::uint64_t seed = 0;
  std::string software_version;
};

struct StudyRow : StudyInfo {
  std::int64_t id = 0;
  std::string protocol_sha256;  // lower-case hex of SHA-256(protocol_json)
  std::string created_utc;      // ISO 8601, e.g. "2024-05-01T12:00:00.123Z"
};

struct SessionRow {
  std::int64_t id = 0;
  std::int64_t participant_id = 0;
  double started_unix_s = 0.0;
  std::optional<double> ended_unix_s;
  std::string device;  // e.g. "sim", "replay", "lsw"
  std::string clock;   // "virtual" or "wall"
  SessionStatus status = SessionStatus::kOpen;
  // The site whose file the session was recorded in (`study merge`); empty
  // for a session of a file never merged (NULL in the file).
  std::string site;
  // The haptic loop's rate [Hz]; nullopt for a session recorded before
  // schema 10.
  std::optional<double> rate_Hz;
  // The model a simulated participant of the session was drawn from
  // (describe_participant_model); empty when none held the device (a
  // person did) or before schema 10.
  std::string participant_model;
};

struct TrainingRow {
  std::int64_t id = 0;  // ignored by add_training
  std::int64_t session_id = 0;
  std::string task;
  double started_unix_s = 0.0;
  std::optional<double> ended_unix_s;
  std::optional<double> duration_s;  // time actually spent training
  int trials = 0;                    // training trials done in full (the task completed)
  int cut_short = 0;                 // training trials that ended before the task was complete
  std::string cut_short_reason;      // why the last of those ended; empty when none was
};

// A trial as scheduled (protocols/schedule.h PlannedTrial).
struct TrialPlan {
  std::int64_t participant_id = 0;
  std::string task;  // "dissection", "clip"
  std::int64_t setting_id = 0;
  int repetition = 0;  // 1-based
  int block = 0;       // 1-based
  int position = 0;    // 1-based position in the participant's schedule
};

struct TrialRow : TrialPlan {
  std::int64_t id = 0;
  TrialStatus status = TrialStatus::kPlanned;
  std::optional<std::int64_t> session_id;
  std::optional<double> started_unix_s;
  std::optional<double> ended_unix_s;  // stays empty for an interrupted trial
  std::string abort_reason;            // empty unless aborted
  // Joined in for export and reports.
  std::string participant_code;
  std::string setting_name;
};

struct EventRow {
  std::int64_t trial_id = 0;
  double t_s = 0.0;  // loop clock
  // TaskEventType names (core/loop/task_event.h) for the VE's events;
  // others come from the runner and the writer: "samples_dropped",
  // "events_dropped", "samples_missing", "operator_note", ...
  std::string type;
  int instrument = -1;  // 0 left, 1 right, -1 the task as a whole
  std::int64_t item_index = 0;  // cell, clip, or a count for the writer's events
  std::string detail;   // free text, may be empty
};

// An operator's action as the console accepted it (table operator_action),
// stored before the console answered.
struct OperatorActionRow {
  std::int64_t id = 0;                     // ignored by add_operator_action
  std::optional<std::int64_t> session_id;  // none: no session ran (a STOP with nothing running)
  std::optional<std::int64_t> trial_id;    // the trial running when it was accepted; none between trials
  double unix_s = 0.0;                     // when it was accepted
  std::optional<double> t_s;  // loop time [s] of that trial's newest sample drained then (with trial_id)
  std::string type;           // "operator_note", "operator_pause", ... "operator_stop" (db/README.md)
  std::string detail;         // the note, the reason, "120 s"; may be empty
  std::string participant_code;  // joined in by operator_actions(); empty without a session
};

struct LoopTimingRow {
  std::optional<LoopTimingSummary> timing;  // empty for trials migrated from schema 1
  std::uint64_t dropped_samples = 0;
  std::uint64_t dropped_events = 0;
};

// What a bulk reader (analyze, export) maps: SQLite clamps it to its
// compile-time SQLITE_MAX_MMAP_SIZE (Debian's: just under 2 GiB) and reads
// the rest of a larger file with read().
inline constexpr std::uint64_t kBulkReadMmapBytes = std::uint64_t{1} << 32;

struct OpenOptions {
  enum class Integrity { kFull, kQuick, kSkip };
  Integrity integrity = Integrity::kFull;
  bool recover = true;     // of dead sessions only; see the header comment
  bool read_only = false;  // no migration and no recovery; the file must be current
  // Read the file's pages through a memory map of up to this many bytes
  // (SQLite's mmap_size; 0: read() into SQLite's page cache). Saves the
  // kernel's copy of every page a bulk reader touches; the price is that
  // an I/O error of the disk under a mapped page ends the process (SIGBUS)
  // instead of failing the query. For readers only: SQLite still writes
  // with write(), so nothing stored depends on it.
  std::uint64_t mmap_bytes = 0;
};

struct RecoveryReport {
  int trials_aborted = 0;
  int sessions_interrupted = 0;
};

// Step 0 of opening, on any connection: throws DbError naming the file when
// it is not SQLite at all (its header says why); an empty file passes.
void refuse_non_sqlite_file(Database& db);

class StudyDb {
 public:
  // Throws DbError naming the file and what failed.
  explicit StudyDb(const std::filesystem::path& path, const OpenOptions& options = {});
  StudyDb(const StudyDb&) = delete;
  StudyDb& operator=(const StudyDb&) = delete;

  // What opening found and did.
  int schema_version_found() const noexcept { return version_found_; }
  const RecoveryReport& recovery() const noexcept { return recovery_; }
  Database& connection() noexcept { return db_; }

  // Recovery (step 4) of one participant, unconditionally: call it only
  // while holding that participant's SessionLock. `reason` replaces
  // kInterruptedReason when the caller knows better.
  RecoveryReport recover_participant(std::int64_t participant_id, std::string_view reason = {});
  const std::string& path() const noexcept { return db_.path(); }

  // --- studies, participants, settings
  std::int64_t add_study(const StudyInfo& info);  // hashes the protocol, stamps the time
  StudyRow study(std::int64_t id);
  std::vector<StudyRow> studies();
  std::int64_t add_participant(std::int64_t study_id, std::string_view code);
  std::optional<std::int64_t> find_participant(std::int64_t study_id, std::string_view code);
  // Stores settings_to_json(settings): every field, no defaults left implicit.
  std::int64_t add_setting(std::int64_t study_id, const NamedSettings& settings);
  std::int64_t add_setting_json(std::int64_t study_id, std::string_view name, std::string_view parameters_json);
  std::string setting_json(std::int64_t setting_id);
  NamedSettings setting(std::int64_t setting_id);  // parsed back with settings_from_json
  // Every setting row of the study (id, name), by id; also those no trial uses yet.
  std::vector<std::pair<std::int64_t, std::string>> settings(std::int64_t study_id);

  // --- sessions and training
  // rate_Hz: the haptic loop's, 150..2000; nullopt when not known (the C
  // study API: the integrator's own loop).
  std::int64_t begin_session(std::int64_t participant_id, std::string_view device, std::string_view clock,
                             std::optional<double> rate_Hz);
  // Once a simulated participant drove one of the session's trials (or its
  // training): the model it was drawn from.
  void set_session_participant_model(std::int64_t session_id, std::string_view model);
  // Every session of the file, by id.
  std::vector<SessionRow> sessions();
  void end_session(std::int64_t session_id, SessionStatus status = SessionStatus::kClosed);
  SessionRow session(std::int64_t id);
  std::int64_t add_training(const TrainingRow& training);
  std::vector<TrainingRow> training(std::int64_t session_id);

  // --- trials
  std::int64_t add_trial(const TrialPlan& plan);
  // planned -> running, stamps the start. Throws DbError if it is not planned.
  void start_trial(std::int64_t trial_id, std::int64_t session_id);
  // running -> complete or aborted, stamps the end. Throws DbError if it is
  // not running or `status` is neither.
  void end_trial(std::int64_t trial_id, TrialStatus status, std::string_view abort_reason = {});
  TrialRow trial(std::int64_t id);
  // All trials (of one study, if given), by participant, position, then id.
  std::vector<TrialRow> trials(std::optional<std::int64_t> study_id = std::nullopt);
  // The participant's next trial to run: the planned one earliest in the
  // schedule; of two at one position (a re-queued copy), the lower id.
  std::optional<std::int64_t> next_planned_trial(std::int64_t participant_id);
  // Re-queues an aborted trial: a planned copy of its plan at the same
  // position, so it runs again in its place in the schedule; returns the
  // copy's id. The aborted trial keeps its samples and status. Throws
  // DbError if the trial is not aborted or its position already holds a
  // trial that is not aborted (planned, running or complete).
  std::int64_t requeue_trial(std::int64_t trial_id);

  // --- events and loop timing
  void add_event(const EventRow& event);
  std::vector<EventRow> events(std::int64_t trial_id);  // by time, then insertion
  void set_loop_timing(std::int64_t trial_id, const LoopTimingSummary& timing, std::uint64_t dropped_samples,
                       std::uint64_t dropped_events);
  std::optional<LoopTimingRow> loop_timing(std::int64_t trial_id);
  // A device's own counts for a trial (Device::counters()), replacing any
  // stored before; read back in name order.
  void set_device_counters(std::int64_t trial_id,
                           const std::vector<std::pair<std::string, std::uint64_t>>& counters);
  std::vector<std::pair<std::string, std::uint64_t>> device_counters(std::int64_t trial_id);

  // --- the operator's actions
  std::int64_t add_operator_action(const OperatorActionRow& action);
  // Every stored action, in the order stored.
  std::vector<OperatorActionRow> operator_actions();

  // --- samples (sample_codec.h)
  // Inserts a chunk; returns its row id. `samples` as for encode_chunk.
  std::int64_t insert_chunk(std::int64_t trial_id, int instrument, std::span<const StoredSample> samples);
  // Replaces the content of chunk `chunk_id` (it grew); same trial,
  // instrument and first tick.
  void update_chunk(std::int64_t chunk_id, std::int64_t trial_id, int instrument,
                    std::span<const StoredSample> samples);
  // Every stored update of one instrument in tick order, decoded. Throws
  // DbError naming a damaged chunk (readers that go on without it use
  // chunk_reader.h).
  std::vector<StoredSample> samples(std::int64_t trial_id, int instrument);
  std::uint64_t sample_count(std::int64_t trial_id, int instrument);

 private:
  void check_integrity(OpenOptions::Integrity level);
  void recover();

  Database db_;
  int version_found_ = 0;
  RecoveryReport recovery_;
};

// Wall-clock now, seconds since 1970 UTC.
double unix_now_s() noexcept;
// Wall-clock now as ISO 8601 UTC with milliseconds: "2024-05-01T12:00:00.123Z".
std::string iso8601_utc_now();

}  // namespace hapticlab::db
