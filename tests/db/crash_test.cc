// Resume after a crash in the middle of a trial: a child process runs a
// trial with a SampleWriter fed at 1 kHz from the wall clock, the parent
// kill -9s it mid-trial, and the database must open, pass integrity_check,
// show the trial aborted with its samples, and have lost at most the last
// 100 ms (the durability requirement).
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <new>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "db/sample_writer.h"
#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using namespace std::chrono_literals;

// The bound on what a kill -9 may lose [s].
constexpr double kMaxLoss_s = 0.100;
// How long the child runs before the kill [s] (of its own trial clock).
constexpr double kRunBeforeKill_s = 0.5;
// Events: one every this many updates, so their consistency with the
// samples can be checked too.
constexpr std::uint64_t kEventEvery = 100;

// Shared between parent and child (an anonymous shared mapping made before
// fork). Lock-free atomics work across processes on one mapping.
struct Progress {
  std::atomic<int> state{0};             // 0 starting, 1 running, -1 the child failed
  std::atomic<double> last_pushed_t_s{-1.0};  // t_s of the last sample the child queued
};
static_assert(std::atomic<double>::is_always_lock_free);

// The child: open, start the trial, write samples until killed. Never
// returns; exits with 2 on an error and 3 if nobody kills it.
[[noreturn]] void run_child(const std::filesystem::path& path, std::int64_t trial, Progress& progress) {
  try {
    StudyDb db(path);
    const TrialRow t = db.trial(trial);
    db.start_trial(trial, db.begin_session(t.participant_id, "sim", "wall", 1000.0));
    SpscQueue<LoopSample> samples(1 << 14);
    SpscQueue<TaskEvent> events(1 << 10);
    SampleWriter writer(path, trial, samples, events);  // the default configuration, as the runner uses
    progress.state.store(1);

    // A 1 kHz producer on the wall clock, as the loop with the wall clock:
    // t_s is the time since the trial began, dt_s the measured period.
    const auto start = std::chrono::steady_clock::now();
    double last_t_s = 0.0;
    for (std::uint64_t tick = 0;; ++tick) {
      const double t_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (t_s > 30.0) ::_exit(3);  // the parent never killed us: do not linger
      LoopSample s = testing::make_sample(tick);
      s.t_s = t_s;
      s.dt_s = tick == 0 ? 0.0 : t_s - last_t_s;
      last_t_s = t_s;
      if (tick % kEventEvery == 0)
        (void)events.try_push({t_s, TaskEventType::kContactStart, 1, static_cast<std::int32_t>(tick / kEventEvery)});
      if (!samples.try_push(s)) ::_exit(4);  // 16 s of queue: cannot fill unless the writer died
      progress.last_pushed_t_s.store(t_s, std::memory_order_release);
      std::this_thread::sleep_until(start + std::chrono::microseconds(1000 * (tick + 1)));
    }
  } catch (...) {
    progress.state.store(-1);
    ::_exit(2);
  }
}

TEST(Crash, KillDuringATrialLosesAtMost100msAndTheTrialIsMarkedAborted) {
  testing::TempDir dir;
  const auto path = dir.file("crash.db");
  std::int64_t trial = 0;
  {
    StudyDb db(path);
    trial = testing::make_trial(db, /*start=*/false);
  }

  void* mem = ::mmap(nullptr, sizeof(Progress), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(mem, MAP_FAILED);
  Progress& progress = *new (mem) Progress;

  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) run_child(path, trial, progress);

  // Let it log for a while, then kill it without warning.
  const auto deadline = std::chrono::steady_clock::now() + 30s;  // generous: ASan on a loaded machine
  double killed_at_t_s = -1.0;
  while (std::chrono::steady_clock::now() < deadline && progress.state.load() >= 0) {
    const double t = progress.last_pushed_t_s.load(std::memory_order_acquire);
    if (progress.state.load() == 1 && t >= kRunBeforeKill_s) {
      killed_at_t_s = t;
      break;
    }
    std::this_thread::sleep_for(1ms);
  }
  ::kill(child, SIGKILL);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)
      << "the child ended by itself (exit " << (WIFEXITED(status) ? WEXITSTATUS(status) : -1) << ")";
  ASSERT_GE(killed_at_t_s, kRunBeforeKill_s) << "the child never got its trial running";
  ::munmap(mem, sizeof(Progress));

  // The file is sound, before anything of ours touches it.
  {
    Database raw(path);
    Statement check = raw.prepare("PRAGMA integrity_check");
    ASSERT_TRUE(check.step());
    EXPECT_EQ(check.column_text(0), "ok");
  }

  // Reopening marks the trial aborted and keeps its samples.
  StudyDb db(path);
  EXPECT_EQ(db.recovery().trials_aborted, 1);
  EXPECT_EQ(db.recovery().sessions_interrupted, 1);
  const TrialRow t = db.trial(trial);
  EXPECT_EQ(t.status, TrialStatus::kAborted);
  EXPECT_EQ(t.abort_reason, kInterruptedReason);

  std::uint64_t last_tick[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const std::vector<StoredSample> got = db.samples(trial, k);
    ASSERT_FALSE(got.empty());
    // Nothing in the middle is lost or damaged: ticks 0..n-1, times rising,
    // every channel as sent.
    for (std::size_t i = 0; i < got.size(); ++i) {
      ASSERT_EQ(got[i].tick, i);
      if (i > 0) {
        ASSERT_GT(got[i].t_s, got[i - 1].t_s);
      }
      const LoopSample want = testing::make_sample(i);
      ASSERT_EQ(got[i].value.raw_position[0],
                double{to_stored_float(want.instrument[static_cast<std::size_t>(k)].raw_position[0])});
    }
    // At most the last 100 ms are lost.
    const double lost_s = killed_at_t_s - got.back().t_s;
    EXPECT_LE(lost_s, kMaxLoss_s) << "instrument " << k << ": last stored sample at " << got.back().t_s
                                  << " s, killed after " << killed_at_t_s << " s";
    last_tick[k] = got.back().tick;
    RecordProperty("lost_ms_instrument_" + std::to_string(k), std::to_string(lost_s * 1e3));
  }
  EXPECT_EQ(last_tick[0], last_tick[1]) << "both instruments are committed together";

  // Every event up to the last stored sample made it (events are committed
  // with, or before, the samples of their update).
  const std::vector<EventRow> events = db.events(trial);
  EXPECT_GE(events.size(), last_tick[0] / kEventEvery + 1);
  for (std::size_t i = 0; i < events.size(); ++i) EXPECT_EQ(events[i].item_index, static_cast<std::int64_t>(i));

  // Resume: the aborted trial is re-queued in its place and is next to run.
  const std::int64_t copy = db.requeue_trial(trial);
  EXPECT_EQ(db.next_planned_trial(t.participant_id), copy);
  EXPECT_EQ(db.samples(trial, 0).size(), last_tick[0] + 1) << "the aborted trial keeps its samples";
}

}  // namespace
}  // namespace hapticlab::db
