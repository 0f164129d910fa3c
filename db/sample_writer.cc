#include "db/sample_writer.h"

#include <time.h>

#include <stdexcept>
#include <utility>
#include <vector>

namespace hapticlab::db {

SampleWriter::SampleWriter(const std::filesystem::path& db_path, std::int64_t trial_id,
                           SpscQueue<LoopSample>& samples, SpscQueue<TaskEvent>& events,
                           const SampleWriterConfig& config)
    : trial_id_(trial_id), samples_(samples), events_(events), config_(config) {
  if (config.commit_interval.count() <= 0)
    throw std::invalid_argument("SampleWriter(): commit_interval is " + std::to_string(config.commit_interval.count()) +
                                " ms, must be > 0");
  if (config.chunk_updates < 1 || config.chunk_updates > kMaxChunkUpdates)
    throw std::invalid_argument("SampleWriter(): chunk_updates is " + std::to_string(config.chunk_updates) +
                                ", must be 1.." + std::to_string(kMaxChunkUpdates));
  if (config.pop_batch < 1) throw std::invalid_argument("SampleWriter(): pop_batch is 0, must be >= 1");

  OpenOptions options;
  options.integrity = OpenOptions::Integrity::kSkip;  // the runner's own open checked it
  options.recover = false;                            // our trial is running on purpose
  db_ = std::make_unique<StudyDb>(db_path, options);
  // Short waits: a commit that loses the lock race is retried on the next
  // pass (flush_and_commit) instead of holding up the draining.
  db_->connection().set_busy_timeout(kBusyWaitPerTry);
  const TrialRow trial = db_->trial(trial_id);
  if (trial.status != TrialStatus::kRunning)
    throw DbError(db_->path() + ": SampleWriter: trial " + std::to_string(trial_id) + " is " +
                  to_string(trial.status) + ", start it (StudyDb::start_trial) before writing samples");
  // Everything the thread needs is allocated here, once: the chunk
  // buffers it fills and the ones it cycles through under a flood.
  batch_.resize(config.pop_batch);
  for (int k = 0; k < 2; ++k) {
    open_[k].instrument = k;
    open_[k].samples.reserve(config.chunk_updates);
  }
  full_.reserve(kMaxPendingChunks + 2);
  uncommitted_rows_.reserve(kMaxPendingChunks + 4);
  spare_.reserve(kMaxPendingChunks + 2);
  thread_ = std::thread([this] { run(); });
}

SampleWriter::~SampleWriter() { stop_thread(); }

void SampleWriter::stop_thread() noexcept {
  if (!thread_.joinable()) return;
  stop_.store(true, std::memory_order_release);
  thread_.join();
}

SampleWriterStats SampleWriter::stats() const noexcept {
  SampleWriterStats s;
  s.updates = updates_.load(std::memory_order_relaxed);
  s.events = events_stored_.load(std::memory_order_relaxed);
  s.commits = commits_.load(std::memory_order_relaxed);
  s.missing_updates = missing_.load(std::memory_order_relaxed);
  s.discarded = discarded_.load(std::memory_order_relaxed);
  s.busy_retries = busy_retries_.load(std::memory_order_relaxed);
  s.thread_cpu_s = thread_cpu_s_.load(std::memory_order_relaxed);
  return s;
}

void SampleWriter::run() noexcept {
  for (;;) {
    // Read the flag before popping: once it is set the producer has
    // stopped, so a pass that then finds both queues empty has seen all.
    const bool stopping = stop_.load(std::memory_order_acquire);
    bool idle = true;
    if (error_ == nullptr) {
      try {
        idle = drain_once() == 0;
        // Checked on every pass, idle or not, so data that arrived just
        // before the producer went quiet is still committed on time.
        if (commit_due()) flush_and_commit();
      } catch (...) {
        error_ = std::current_exception();
        // First: whoever sees a flag below finds the device already stopped.
        if (config_.on_failure) config_.on_failure();
        failed_.store(true, std::memory_order_release);
        if (config_.failed_flag != nullptr) config_.failed_flag->store(true, std::memory_order_release);
      }
    }
    if (error_ != nullptr) {
      // Keep the queues moving (see header) and count what is lost.
      LoopSample sink[64];
      TaskEvent event_sink[64];
      const std::size_t n = samples_.pop_bulk(sink, 64);
      discarded_.fetch_add(n, std::memory_order_relaxed);
      idle = n == 0 && events_.pop_bulk(event_sink, 64) == 0;
    }
    if (idle) {
      if (stopping) break;
      std::this_thread::sleep_for(config_.idle_poll);
    }
  }
  if (error_ == nullptr) {
    try {
      // Until it is in: a try that lost the lock race leaves it pending,
      // and flush_and_commit throws once kBusyPatience has passed.
      while (pending_) flush_and_commit();
    } catch (...) {
      error_ = std::current_exception();
    }
  }
  timespec cpu{};
  if (::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cpu) == 0)
    thread_cpu_s_.store(static_cast<double>(cpu.tv_sec) + 1e-9 * static_cast<double>(cpu.tv_nsec),
                        std::memory_order_relaxed);
}

// One bulk of each queue per call, so the commit check stays timely under
// a flood. Returns how many items it popped. Samples first, then events:
// the loop queues an update's events before its sample, so in this order
// every event up to the last popped sample is in hand, and a commit never
// holds a sample without the events that led up to it.
std::size_t SampleWriter::drain_once() {
  const std::size_t n = samples_.pop_bulk(batch_.data(), batch_.size());
  TaskEvent events[64];
  const std::size_t m = events_.pop_bulk(events, 64);
  if (n + m == 0) return 0;
  if (!pending_) {
    pending_ = true;
    pending_since_ = std::chrono::steady_clock::now();
  }
  for (std::size_t i = 0; i < m; ++i) {
    const TaskEvent& e = events[i];
    pending_events_.push_back({trial_id_, e.t_s, to_string(e.type), e.instrument, e.index, {}});
  }
  pending_task_events_ += m;
  for (std::size_t i = 0; i < n; ++i) store_sample(batch_[i]);
  pending_updates_ += n;
  if (config_.observe && n > 0) config_.observe(std::span<const LoopSample>(batch_.data(), n));
  return n + m;
}

void SampleWriter::store_sample(const LoopSample& sample) {
  if (have_tick_ && sample.tick != last_tick_ + 1) {
    if (sample.tick <= last_tick_)
      throw DbError(db_->path() + ": SampleWriter: trial " + std::to_string(trial_id_) + ": tick " +
                    std::to_string(sample.tick) + " after tick " + std::to_string(last_tick_) +
                    " (ticks must increase)");
    const std::uint64_t missing = sample.tick - last_tick_ - 1;
    missing_.fetch_add(missing, std::memory_order_relaxed);
    pending_events_.push_back({trial_id_, sample.t_s, "samples_missing", -1, static_cast<std::int64_t>(missing),
                               "updates " + std::to_string(last_tick_ + 1) + ".." + std::to_string(sample.tick - 1) +
                                   " never reached the writer (a full sample queue, or refused by the study API)"});
  }
  have_tick_ = true;
  last_tick_ = sample.tick;
  last_t_s_ = sample.t_s;
  for (int k = 0; k < 2; ++k) {
    OpenChunk& c = open_[k];
    // A chunk holds consecutive ticks only: a gap closes it.
    if (!c.samples.empty() && c.samples.back().tick + 1 != sample.tick) close_chunk(k);
    c.samples.push_back({sample.tick, sample.t_s, sample.dt_s, sample.device_status,
                         sample.instrument[static_cast<std::size_t>(k)]});
    if (c.samples.size() >= config_.chunk_updates) close_chunk(k);
  }
}

// The open chunk is complete: park it for the next commit and start a new
// one in a recycled buffer.
void SampleWriter::close_chunk(int instrument) {
  OpenChunk& c = open_[instrument];
  OpenChunk done;
  done.instrument = instrument;
  done.row_id = c.row_id;
  done.samples = std::move(c.samples);
  full_.push_back(std::move(done));
  c.row_id = 0;
  if (!spare_.empty()) {
    c.samples = std::move(spare_.back());
    spare_.pop_back();
  } else {
    c.samples = std::vector<StoredSample>();
    c.samples.reserve(config_.chunk_updates);
  }
}

void SampleWriter::write_chunk(OpenChunk& c) {
  if (c.samples.empty()) return;
  if (c.row_id == 0) {
    c.row_id = db_->insert_chunk(trial_id_, c.instrument, c.samples);
    uncommitted_rows_.push_back(&c);
  } else {
    db_->update_chunk(c.row_id, trial_id_, c.instrument, c.samples);
  }
}

bool SampleWriter::commit_due() const noexcept {
  if (!pending_) return false;
  return full_.size() >= kMaxPendingChunks ||
         std::chrono::steady_clock::now() - pending_since_ >= config_.commit_interval;
}

void SampleWriter::flush_and_commit() {
  if (!pending_) return;
  // A chunk first inserted in a transaction that then fails gets a row id
  // that was never committed: remember which to undo.
  uncommitted_rows_.clear();
  try {
    Transaction tx(db_->connection());
    for (OpenChunk& c : full_) write_chunk(c);
    // Partial chunks go in too (and are rewritten in place as they grow), so
    // a crash loses at most one commit interval.
    for (OpenChunk& c : open_) write_chunk(c);
    for (const EventRow& e : pending_events_) db_->add_event(e);
    tx.commit();
  } catch (const DbError& e) {
    for (OpenChunk* c : uncommitted_rows_) c->row_id = 0;
    if (!e.is_busy()) throw;
    // Another connection (a second station's writer, a program holding a
    // write transaction) has the lock. Everything stays pending, in memory,
    // and the next pass tries again; meanwhile the queues keep draining,
    // so losing the race never stalls the loop or aborts the trial.
    const auto now = std::chrono::steady_clock::now();
    if (!busy_since_) busy_since_ = now;
    busy_retries_.fetch_add(1, std::memory_order_relaxed);
    if (now - *busy_since_ >= kBusyPatience)
      throw DbError(std::string(e.what()) + " (the database stayed locked by another connection for " +
                        std::to_string(std::chrono::duration_cast<std::chrono::seconds>(now - *busy_since_).count()) +
                        " s)",
                    e.sqlite_code());
    return;
  }
  busy_since_.reset();

  // Committed: account for it and recycle the closed chunks' buffers.
  updates_.fetch_add(pending_updates_, std::memory_order_relaxed);
  events_stored_.fetch_add(pending_task_events_, std::memory_order_relaxed);
  commits_.fetch_add(1, std::memory_order_relaxed);
  for (OpenChunk& c : full_) {
    c.samples.clear();
    spare_.push_back(std::move(c.samples));
  }
  full_.clear();
  pending_events_.clear();
  pending_updates_ = 0;
  pending_task_events_ = 0;
  pending_ = false;
}

void SampleWriter::finish(const TrialOutcome& outcome) {
  if (finished_) throw std::logic_error("SampleWriter::finish(): called twice");
  finished_ = true;
  stop_thread();
  if (error_ != nullptr) {
    try {
      std::rethrow_exception(error_);
    } catch (const std::exception& e) {
      throw DbError(std::string(e.what()) + " (sample writer for trial " + std::to_string(trial_id_) + "; " +
                    std::to_string(discarded_.load()) + " later updates discarded)");
    }
  }
  // The closing transaction waits out another connection's lock too (the
  // loop has stopped, so blocking here costs nothing), within the same
  // patience as the samples.
  const auto first_try = std::chrono::steady_clock::now();
  for (;;) {
    try {
      close_trial(outcome);
      return;
    } catch (const DbError& e) {
      if (!e.is_busy() || std::chrono::steady_clock::now() - first_try >= kBusyPatience) throw;
      busy_retries_.fetch_add(1, std::memory_order_relaxed);
    }
  }
}

void SampleWriter::close_trial(const TrialOutcome& outcome) {
  Transaction tx(db_->connection());
  db_->set_loop_timing(trial_id_, outcome.timing, outcome.dropped_samples, outcome.dropped_events);
  if (!outcome.device_counters.empty()) db_->set_device_counters(trial_id_, outcome.device_counters);
  if (outcome.dropped_samples > 0)
    db_->add_event({trial_id_, last_t_s_, "samples_dropped", -1, static_cast<std::int64_t>(outcome.dropped_samples),
                    "the haptic loop's sample queue was full: " + std::to_string(outcome.dropped_samples) +
                        " updates were not logged (" + std::to_string(missing_.load()) +
                        " of them seen as tick gaps)"});
  if (outcome.dropped_events > 0)
    db_->add_event({trial_id_, last_t_s_, "events_dropped", -1, static_cast<std::int64_t>(outcome.dropped_events),
                    "the haptic loop's event queue was full: " + std::to_string(outcome.dropped_events) +
                        " task events were not logged"});
  for (EventRow e : outcome.closing_events) {
    e.trial_id = trial_id_;
    db_->add_event(e);
  }
  db_->end_trial(trial_id_, outcome.status, outcome.abort_reason);
  tx.commit();
}

}  // namespace hapticlab::db
