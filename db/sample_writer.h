#pragma once
// SampleWriter: the thread that moves one trial's samples and task events
// from the haptic loop's lock-free queues into the study database.
//
//   loop thread ──try_push──► SpscQueue<LoopSample>, SpscQueue<TaskEvent>
//                                   │ pop_bulk (this thread, the only consumer)
//                                   ▼
//   per instrument: an open chunk of consecutive updates ──► sample_chunk rows
//   events ──► event rows;  every commit_interval: COMMIT
//
// The producer is never blocked: this thread only pops, and sleeps
// idle_poll when both queues are empty (the loop does not signal, since a
// real-time thread must not make system calls to wake another).
//
// Durability: data popped from the queue waits in memory and is committed
// at most commit_interval after the first of it was popped (sooner under a
// flood, when kMaxPendingChunks chunks have filled); the open chunk is
// written at every commit and rewritten in place while it grows, so a
// killed process loses about the last commit_interval of samples (plus
// what was still in the queue) and chunks stay full-sized. Each commit is
// one short transaction, so other connections can write in between.
//
// Drops are never silent. A tick that jumps forward (the loop dropped
// updates in between) is logged at once as a "samples_missing" event with
// the number of missing updates. finish() records the loop's own drop
// counts in loop_timing and, when non-zero, as "samples_dropped" /
// "events_dropped" events.
//
// Concurrency: a commit that finds the database locked by another
// connection is retried (kBusyWaitPerTry, kBusyPatience below); losing the
// lock race never aborts a trial.
//
// Errors: if the database fails (disk full, ...), the thread keeps popping
// and discards what it pops, so a producer that waits on a full queue (the
// virtual clock) is not stalled; finish() then throws the first error with
// the number of updates discarded.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "core/loop/loop_sample.h"
#include "core/loop/loop_timing.h"
#include "core/loop/spsc_queue.h"
#include "core/loop/task_event.h"
#include "db/study_db.h"

namespace hapticlab::db {

// Full chunks (per both instruments) held before a commit is forced, which
// bounds the writer's memory when the queue is flooded.
inline constexpr std::size_t kMaxPendingChunks = 16;

// Another connection holding the write lock (a second station, a program
// in a write transaction) makes a commit wait up to kBusyWaitPerTry, then
// the writer goes back to draining and tries again on its next pass, with
// everything kept in memory. Only a lock held for kBusyPatience in all is
// an error: at 1 kHz that is 60 s of samples, ~12 MB, waiting in memory.
inline constexpr std::chrono::milliseconds kBusyWaitPerTry{200};
inline constexpr std::chrono::seconds kBusyPatience{60};

struct SampleWriterConfig {
  // > 0. Popped data is committed at most this long after it was popped,
  // so a killed process loses about this much plus what was still queued;
  // 50 ms leaves margin under the 100 ms for a loaded machine.
  std::chrono::milliseconds commit_interval{50};
  std::size_t chunk_updates = 1000;                // updates per chunk and instrument, 1..kMaxChunkUpdates
  std::size_t pop_batch = 1024;                    // LoopSamples popped at once, >= 1
  // Sleep when both queues are empty. At 1 kHz the queues hold seconds, so
  // a few ms costs nothing but wakes the writer (and disturbs the loop's
  // core) 5x less often than 1 ms; it adds at most this much to what a
  // crash can lose (commit_interval + idle_poll, 55 ms by default).
  std::chrono::microseconds idle_poll{5000};
  // Called on the writer's thread with every batch of samples it popped,
  // in order (e.g. the operator console's live view, which decimates):
  // watching costs the writer, never the haptic loop. May be empty; must
  // not throw or block for long.
  std::function<void(std::span<const LoopSample>)> observe;
  // Set (true) too when the writer fails: a flag that outlives the writer,
  // for a producer on another thread that must stop handing in data that
  // is now lost (the C study API's log calls). May be null.
  std::atomic<bool>* failed_flag = nullptr;
  // Called once on the writer's thread when it fails, before failed_flag is
  // set: for a producer whose device must stop at once, before its next
  // log call (the C study API halts the trial's engine). May be empty;
  // must not throw.
  std::function<void()> on_failure;
};

struct TrialOutcome {
  TrialStatus status = TrialStatus::kComplete;  // kComplete or kAborted
  std::string abort_reason;                     // for kAborted
  std::uint64_t dropped_samples = 0;            // HapticLoop::dropped_samples()
  std::uint64_t dropped_events = 0;             // HapticLoop::dropped_events()
  LoopTimingSummary timing;                     // HapticLoop::timing()
  // Device::counters(), stored in device_counter; empty for most devices.
  std::vector<std::pair<std::string, std::uint64_t>> device_counters;
  // Events the caller adds to the trial's record (an operator's stop), in the
  // closing transaction: after every event the loop queued, so at an equal
  // time they sort last, and together with the status. trial_id is set here.
  std::vector<EventRow> closing_events;
};

// Counters, readable from any thread while the writer runs.
struct SampleWriterStats {
  std::uint64_t updates = 0;          // LoopSamples committed (2 instrument-samples each)
  std::uint64_t events = 0;           // TaskEvents committed
  std::uint64_t commits = 0;
  std::uint64_t missing_updates = 0;  // sum of tick jumps seen
  std::uint64_t discarded = 0;        // LoopSamples popped after a database error
  std::uint64_t busy_retries = 0;     // commits retried because another connection held the lock
  // CPU time the writer thread used [s], set when the thread ends (0 while
  // it runs): what logging costs, independent of what else the machine does.
  double thread_cpu_s = 0.0;
};

class SampleWriter {
 public:
  // Opens its own connection to the study database at `db_path` (no
  // recovery: the trial is running) and starts the thread. The trial must
  // exist and be 'running' (StudyDb::start_trial). The queues must outlive
  // the writer. Throws DbError or std::invalid_argument.
  SampleWriter(const std::filesystem::path& db_path, std::int64_t trial_id, SpscQueue<LoopSample>& samples,
               SpscQueue<TaskEvent>& events, const SampleWriterConfig& config = {});
  // Without finish(): drains, commits what it has and stops, leaving the
  // trial 'running' (the next open marks it interrupted). Never throws.
  ~SampleWriter();
  SampleWriter(const SampleWriter&) = delete;
  SampleWriter& operator=(const SampleWriter&) = delete;

  // Call after the producer has stopped (HapticLoop::join). Drains both
  // queues, stores everything, then in one transaction: loop timing and
  // drop counts, drop events, and the trial's end status. Throws DbError
  // for a database failure during the trial or now.
  void finish(const TrialOutcome& outcome);

  SampleWriterStats stats() const noexcept;
  // True once the database has failed (disk full, ...): from then on what
  // the loop produces is discarded, so the caller should end the trial.
  bool failed() const noexcept { return failed_.load(std::memory_order_acquire); }
  std::int64_t trial_id() const noexcept { return trial_id_; }

 private:
  // Consecutive updates of one instrument, and the row holding them once
  // they have been written (0: not yet).
  struct OpenChunk {
    int instrument = 0;
    std::vector<StoredSample> samples;
    std::int64_t row_id = 0;
  };
  void run() noexcept;
  std::size_t drain_once();
  void store_sample(const LoopSample& sample);
  void close_chunk(int instrument);
  void write_chunk(OpenChunk& chunk);
  bool commit_due() const noexcept;
  void flush_and_commit();
  void close_trial(const TrialOutcome& outcome);
  void stop_thread() noexcept;

  const std::int64_t trial_id_;
  SpscQueue<LoopSample>& samples_;
  SpscQueue<TaskEvent>& events_;
  const SampleWriterConfig config_;
  std::unique_ptr<StudyDb> db_;  // used by the thread, then by finish() after join
  std::vector<LoopSample> batch_;  // pop_bulk target

  // Thread state. What was popped waits here, in memory, for the next
  // commit, which writes it all in one short transaction: the write lock
  // is held for milliseconds, not for the whole commit interval, so the
  // runner's own connection can write (an operator note) mid-trial.
  OpenChunk open_[2];                     // growing chunk per instrument
  std::vector<OpenChunk> full_;           // chunks closed since the last commit
  std::vector<std::vector<StoredSample>> spare_;  // emptied buffers, reused
  std::vector<EventRow> pending_events_;
  std::uint64_t pending_updates_ = 0;     // LoopSamples popped since the last commit
  std::uint64_t pending_task_events_ = 0;  // TaskEvents among pending_events_
  bool pending_ = false;                  // anything to commit
  std::chrono::steady_clock::time_point pending_since_;
  bool have_tick_ = false;
  std::uint64_t last_tick_ = 0;
  double last_t_s_ = 0.0;
  std::exception_ptr error_;
  std::vector<OpenChunk*> uncommitted_rows_;  // chunks given a row id by the current transaction
  std::optional<std::chrono::steady_clock::time_point> busy_since_;  // first failed try of the pending data

  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> updates_{0}, events_stored_{0}, commits_{0}, missing_{0}, discarded_{0},
      busy_retries_{0};
  std::atomic<double> thread_cpu_s_{0.0};
  std::atomic<bool> failed_{false};
  std::thread thread_;
  bool finished_ = false;
};

}  // namespace hapticlab::db
