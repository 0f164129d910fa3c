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
// idle_poll when both queues are empty (the loop does not signal).
//
// Durability: data popped from the queue is committed at most
// commit_interval after the transaction holding it began; the open chunk
// is written at every commit and rewritten in place while it grows, so a
// killed process loses about the last commit_interval of samples (plus
// what was still in the queue) and chunks stay full-sized.
//
// Drops are never silent. A tick that jumps forward (the loop dropped
// updates in between) is logged at once as a "samples_missing" event with
// the number of missing updates. finish() records the loop's own drop
// counts in loop_timing and, when non-zero, as "samples_dropped" /
// "events_dropped" events.
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
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "core/loop/loop_sample.h"
#include "core/loop/loop_timing.h"
#include "core/loop/spsc_queue.h"
#include "core/sim/task_event.h"
#include "db/study_db.h"

namespace hapticlab::db {

struct SampleWriterConfig {
  std::chrono::milliseconds commit_interval{100};  // > 0
  std::size_t chunk_updates = 1000;                // updates per chunk and instrument, 1..kMaxChunkUpdates
  std::size_t pop_batch = 1024;                    // LoopSamples popped at once, >= 1
  std::chrono::microseconds idle_poll{1000};       // sleep when both queues are empty
};

struct TrialOutcome {
  TrialStatus status = TrialStatus::kComplete;  // kComplete or kAborted
  std::string abort_reason;                     // for kAborted
  std::uint64_t dropped_samples = 0;            // HapticLoop::dropped_samples()
  std::uint64_t dropped_events = 0;             // HapticLoop::dropped_events()
  LoopTimingSummary timing;                     // HapticLoop::timing()
};

// Counters, readable from any thread while the writer runs.
struct SampleWriterStats {
  std::uint64_t updates = 0;          // LoopSamples stored (2 instrument-samples each)
  std::uint64_t events = 0;           // TaskEvents stored
  std::uint64_t commits = 0;
  std::uint64_t missing_updates = 0;  // sum of tick jumps seen
  std::uint64_t discarded = 0;        // LoopSamples popped after a database error
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
  std::int64_t trial_id() const noexcept { return trial_id_; }

 private:
  struct OpenChunk;
  void run() noexcept;
  void drain_once();
  void store_sample(const LoopSample& sample);
  void write_chunk(int instrument, bool keep_open);
  void flush_and_commit();
  void stop_thread() noexcept;

  const std::int64_t trial_id_;
  SpscQueue<LoopSample>& samples_;
  SpscQueue<TaskEvent>& events_;
  const SampleWriterConfig config_;
  std::unique_ptr<StudyDb> db_;  // used by the thread, then by finish() after join
  std::unique_ptr<OpenChunk[]> chunks_;  // one per instrument
  std::vector<LoopSample> batch_;        // pop_bulk target

  // Thread state.
  std::unique_ptr<Transaction> tx_;
  std::chrono::steady_clock::time_point tx_began_;
  bool have_tick_ = false;
  std::uint64_t last_tick_ = 0;
  double last_t_s_ = 0.0;
  std::exception_ptr error_;

  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> updates_{0}, events_stored_{0}, commits_{0}, missing_{0}, discarded_{0};
  std::thread thread_;
  bool finished_ = false;
};

}  // namespace hapticlab::db
