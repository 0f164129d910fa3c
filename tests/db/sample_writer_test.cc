#include "db/sample_writer.h"

#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using namespace std::chrono_literals;

// What the codec promises for a physical channel: the nearest float32.
double stored(double x) { return double{to_stored_float(x)}; }

void expect_stored_equals(const StoredSample& got, const LoopSample& want, int instrument) {
  const InstrumentSample& w = want.instrument[static_cast<std::size_t>(instrument)];
  const InstrumentSample& g = got.value;
  ASSERT_EQ(got.tick, want.tick);
  EXPECT_EQ(got.t_s, want.t_s) << "tick " << want.tick;
  EXPECT_EQ(got.dt_s, want.dt_s) << "tick " << want.tick;
  EXPECT_EQ(got.device_status, want.device_status) << "tick " << want.tick;
  for (std::size_t j = 0; j < 5; ++j) EXPECT_EQ(g.raw_position[j], stored(w.raw_position[j])) << "tick " << want.tick;
  for (std::size_t j = 0; j < 3; ++j) {
    EXPECT_EQ(g.degraded_position[j], stored(w.degraded_position[j]));
    EXPECT_EQ(g.tip_position_m[j], stored(w.tip_position_m[j]));
    EXPECT_EQ(g.tip_velocity_m_per_s[j], stored(w.tip_velocity_m_per_s[j]));
    EXPECT_EQ(g.ve_force_N[j], stored(w.ve_force_N[j]));
    EXPECT_EQ(g.displayed_force_N[j], stored(w.displayed_force_N[j]));
    EXPECT_EQ(g.joint_force[j], stored(w.joint_force[j]));
  }
  EXPECT_EQ(g.engine_status, w.engine_status) << "tick " << want.tick;
  EXPECT_EQ(g.in_contact, w.in_contact) << "tick " << want.tick;
}

// Pushes, waiting while the queue is full, as the virtual-clock loop does.
template <typename T>
void push(SpscQueue<T>& q, const T& item) {
  while (!q.try_push(item)) std::this_thread::yield();
}

std::int64_t chunk_rows(StudyDb& db, std::int64_t trial, int instrument) {
  Statement s = db.connection().prepare("SELECT count(*) FROM sample_chunk WHERE trial_id = ?1 AND instrument = ?2");
  s.bind(1, trial).bind(2, std::int64_t{instrument});
  s.step();
  return s.column_int64(0);
}

struct Fixture {
  testing::TempDir dir;
  std::filesystem::path path = dir.file("study.db");
  std::int64_t trial = 0;
  SpscQueue<LoopSample> samples{256};
  SpscQueue<TaskEvent> events{64};
  Fixture() {
    StudyDb db(path);
    trial = testing::make_trial(db);
  }
};

TEST(SampleWriter, SamplesAndEventsLandExactlyWhileTheProducerRuns) {
  Fixture f;
  constexpr std::uint64_t kUpdates = 2'500;  // 2 full chunks of 1000 and a partial one
  std::vector<TaskEvent> sent_events;
  for (int k = 0; k < 5; ++k)
    sent_events.push_back({0.1 * k + 0.05, static_cast<TaskEventType>(k * 2), static_cast<std::int8_t>(k % 3 - 1),
                           k * 7});
  SampleWriterConfig config;
  config.pop_batch = 100;  // many small pops, so the open chunk grows across commits
  config.commit_interval = 5ms;
  SampleWriter writer(f.path, f.trial, f.samples, f.events, config);
  // The queue (256) is far smaller than the trial: the producer runs
  // alongside the writer, as the loop does.
  std::thread producer([&] {
    for (std::uint64_t t = 0; t < kUpdates; ++t) {
      if (t % 500 == 0) push(f.events, sent_events[t / 500]);
      push(f.samples, testing::make_sample(t));
    }
  });
  producer.join();
  TrialOutcome outcome;
  outcome.timing.count = kUpdates - 1;
  outcome.timing.p99_period_s = 1.02e-3;
  writer.finish(outcome);
  EXPECT_EQ(writer.stats().updates, kUpdates);
  EXPECT_EQ(writer.stats().events, sent_events.size());
  EXPECT_EQ(writer.stats().missing_updates, 0u);
  EXPECT_GE(writer.stats().commits, 1u);

  StudyDb db(f.path);
  for (int k = 0; k < 2; ++k) {
    const std::vector<StoredSample> got = db.samples(f.trial, k);
    ASSERT_EQ(got.size(), kUpdates);
    for (std::uint64_t t = 0; t < kUpdates; ++t) expect_stored_equals(got[t], testing::make_sample(t), k);
    EXPECT_EQ(chunk_rows(db, f.trial, k), 3) << "chunks stay full-sized although written at every commit";
  }
  const std::vector<EventRow> events = db.events(f.trial);
  ASSERT_EQ(events.size(), sent_events.size());
  for (std::size_t i = 0; i < events.size(); ++i) {
    EXPECT_EQ(events[i].t_s, sent_events[i].t_s);
    EXPECT_EQ(events[i].type, to_string(sent_events[i].type));
    EXPECT_EQ(events[i].instrument, sent_events[i].instrument);
    EXPECT_EQ(events[i].item_index, sent_events[i].index);
  }
  const TrialRow t = db.trial(f.trial);
  EXPECT_EQ(t.status, TrialStatus::kComplete);
  ASSERT_TRUE(t.started_unix_s && t.ended_unix_s);
  EXPECT_LE(*t.started_unix_s, *t.ended_unix_s);
  const std::optional<LoopTimingRow> timing = db.loop_timing(f.trial);
  ASSERT_TRUE(timing && timing->timing);
  EXPECT_EQ(timing->timing->count, kUpdates - 1);
  EXPECT_EQ(timing->timing->p99_period_s, 1.02e-3);
  EXPECT_EQ(timing->dropped_samples, 0u);
}

TEST(SampleWriter, TickGapIsLoggedAtOnceAndDropCountsAtFinish) {
  Fixture f;
  SampleWriter writer(f.path, f.trial, f.samples, f.events);
  for (std::uint64_t t = 0; t < 100; ++t) push(f.samples, testing::make_sample(t));
  for (std::uint64_t t = 150; t < 200; ++t) push(f.samples, testing::make_sample(t));  // 100..149 lost
  TrialOutcome outcome;
  outcome.status = TrialStatus::kAborted;
  outcome.abort_reason = "operator abort";
  outcome.dropped_samples = 50;
  outcome.dropped_events = 2;
  writer.finish(outcome);
  EXPECT_EQ(writer.stats().missing_updates, 50u);

  StudyDb db(f.path);
  for (int k = 0; k < 2; ++k) {
    const std::vector<StoredSample> got = db.samples(f.trial, k);
    ASSERT_EQ(got.size(), 150u);
    EXPECT_EQ(got[99].tick, 99u);
    EXPECT_EQ(got[100].tick, 150u);
    expect_stored_equals(got[100], testing::make_sample(150), k);
    EXPECT_EQ(chunk_rows(db, f.trial, k), 2) << "a chunk holds consecutive ticks only";
  }
  const std::vector<EventRow> events = db.events(f.trial);
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].type, "samples_missing");
  EXPECT_EQ(events[0].item_index, 50);
  EXPECT_EQ(events[0].t_s, testing::make_sample(150).t_s);
  EXPECT_THAT(events[0].detail, HasSubstr("100..149"));
  EXPECT_EQ(events[1].type, "samples_dropped");
  EXPECT_EQ(events[1].item_index, 50);
  EXPECT_EQ(events[2].type, "events_dropped");
  EXPECT_EQ(events[2].item_index, 2);
  const std::optional<LoopTimingRow> timing = db.loop_timing(f.trial);
  ASSERT_TRUE(timing.has_value());
  EXPECT_EQ(timing->dropped_samples, 50u);
  EXPECT_EQ(timing->dropped_events, 2u);
  const TrialRow t = db.trial(f.trial);
  EXPECT_EQ(t.status, TrialStatus::kAborted);
  EXPECT_EQ(t.abort_reason, "operator abort");
  EXPECT_TRUE(t.ended_unix_s.has_value());
}

TEST(SampleWriter, ClosingEventsComeAfterEveryQueuedEventOfTheSameTime) {
  // The session runner's operator_abort, at the loop time of the last
  // update: an event the loop queued in that same update, still in the queue
  // when finish() is called, must not sort after it.
  Fixture f;
  SampleWriter writer(f.path, f.trial, f.samples, f.events);
  for (std::uint64_t t = 0; t < 10; ++t) push(f.samples, testing::make_sample(t));
  const double last_s = testing::make_sample(9).t_s;
  push(f.events, TaskEvent{last_s, TaskEventType::kInsertionPassed, 1, 0});
  TrialOutcome outcome;
  outcome.status = TrialStatus::kAborted;
  outcome.abort_reason = "operator stopped the session";
  outcome.closing_events.push_back({0, last_s, "operator_abort", -1, 0, "operator stopped the session"});
  writer.finish(outcome);

  StudyDb db(f.path);
  const std::vector<EventRow> events = db.events(f.trial);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].type, "insertion_passed_20mm");
  EXPECT_EQ(events[1].type, "operator_abort");
  EXPECT_EQ(events[1].t_s, last_s);
  EXPECT_EQ(db.trial(f.trial).status, TrialStatus::kAborted);
}

TEST(SampleWriter, DataIsCommittedWithinTheIntervalWithoutFinish) {
  Fixture f;
  SampleWriter writer(f.path, f.trial, f.samples, f.events);
  for (std::uint64_t t = 0; t < 40; ++t) push(f.samples, testing::make_sample(t));
  push(f.events, TaskEvent{0.02, TaskEventType::kContactStart, 1, 0});
  // The producer is now quiet; what it sent must still reach the file.
  OpenOptions reader;
  reader.recover = false;
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  std::uint64_t seen = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    StudyDb db(f.path, reader);
    seen = db.sample_count(f.trial, 1);
    // The writer counts what it committed just after the commit: a reader
    // can see the rows a moment before the counters move (it failed so once
    // on a loaded machine), so both are waited for.
    if (seen == 40 && db.events(f.trial).size() == 1 && writer.stats().updates == 40 && writer.stats().events == 1)
      break;
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_EQ(seen, 40u);
  EXPECT_EQ(writer.stats().updates, 40u);
  EXPECT_EQ(writer.stats().events, 1u);
}

TEST(SampleWriter, DestructorWithoutFinishLeavesTheTrialRunningForRecovery) {
  Fixture f;
  {
    SampleWriter writer(f.path, f.trial, f.samples, f.events);
    for (std::uint64_t t = 0; t < 300; ++t) push(f.samples, testing::make_sample(t));
    // The runner dies an orderly death (an exception unwinds it): no finish().
  }
  OpenOptions reader;
  reader.recover = false;
  {
    StudyDb db(f.path, reader);
    EXPECT_EQ(db.trial(f.trial).status, TrialStatus::kRunning);
    EXPECT_EQ(db.sample_count(f.trial, 0), 300u) << "the destructor drains and commits";
    EXPECT_FALSE(db.loop_timing(f.trial).has_value());
  }
  StudyDb db(f.path);
  EXPECT_EQ(db.recovery().trials_aborted, 1);
  const TrialRow t = db.trial(f.trial);
  EXPECT_EQ(t.status, TrialStatus::kAborted);
  EXPECT_EQ(t.abort_reason, kInterruptedReason);
  EXPECT_EQ(db.samples(f.trial, 1).size(), 300u);
}

// Each commit is a short transaction, so the runner's own connection can
// write during the trial without waiting out the busy timeout.
TEST(SampleWriter, AnotherConnectionCanWriteWhileSamplesFlood) {
  Fixture f;
  SampleWriterConfig config;
  config.commit_interval = 20ms;
  SampleWriter writer(f.path, f.trial, f.samples, f.events, config);
  std::atomic<bool> stop{false};
  std::thread producer([&] {
    for (std::uint64_t t = 0; !stop.load(); ++t) push(f.samples, testing::make_sample(t));
  });
  StudyDb runner(f.path, {OpenOptions::Integrity::kSkip, /*recover=*/false});
  double worst_s = 0.0;
  for (int i = 0; i < 20; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    runner.add_event({f.trial, 0.001 * i, "operator_note", -1, i, "mid-trial note"});
    worst_s = std::max(worst_s, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    std::this_thread::sleep_for(2ms);
  }
  stop = true;
  producer.join();
  writer.finish({});
  // The busy timeout is 5 s; a writer that held the lock for its whole
  // commit interval made this wait for seconds.
  EXPECT_LT(worst_s, 1.0);
  EXPECT_GT(writer.stats().updates, 0u);
  EXPECT_EQ(runner.events(f.trial).size(), 20u);
}

TEST(SampleWriter, ADatabaseErrorKeepsTheQueueMovingAndIsReportedByFinish) {
  Fixture f;
  SampleWriter writer(f.path, f.trial, f.samples, f.events);
  push(f.samples, testing::make_sample(10));
  push(f.samples, testing::make_sample(5));  // ticks going backwards: refused
  // The producer must never stall on a writer that failed.
  for (std::uint64_t t = 11; t < 2'000; ++t) push(f.samples, testing::make_sample(t));
  try {
    writer.finish({});
    FAIL() << "finish() hid the writer's error";
  } catch (const DbError& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr(f.path.string()), HasSubstr("tick 5 after tick 10"),
                                HasSubstr("trial " + std::to_string(f.trial))));
  }
  EXPECT_GT(writer.stats().discarded, 0u);
  StudyDb db(f.path, {OpenOptions::Integrity::kFull, /*recover=*/false});
  EXPECT_EQ(db.trial(f.trial).status, TrialStatus::kRunning) << "the runner decides how the trial ends";
}

TEST(SampleWriter, RefusesBadConfigurationAndATrialThatIsNotRunning) {
  Fixture f;
  SampleWriterConfig bad;
  bad.chunk_updates = 0;
  try {
    SampleWriter w(f.path, f.trial, f.samples, f.events, bad);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("chunk_updates is 0"), HasSubstr("1..")));
  }
  bad = {};
  bad.commit_interval = 0ms;
  EXPECT_THROW(SampleWriter(f.path, f.trial, f.samples, f.events, bad), std::invalid_argument);

  std::int64_t planned = 0;
  {
    StudyDb db(f.path);
    planned = db.add_trial({db.trial(f.trial).participant_id, "clip", db.trial(f.trial).setting_id, 1, 1, 9});
  }
  try {
    SampleWriter w(f.path, planned, f.samples, f.events);
    FAIL();
  } catch (const DbError& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("trial " + std::to_string(planned) + " is planned"),
                                HasSubstr("start_trial")));
  }
  EXPECT_THROW(SampleWriter(f.path, 999, f.samples, f.events), DbError);
}

// A second station's writer, or any program in a write transaction, can
// hold the lock longer than one try waits (kBusyWaitPerTry). The writer
// keeps draining into memory, tries again, and loses nothing; before, the
// first SQLITE_BUSY discarded the rest of the trial.
TEST(SampleWriter, ALockHeldByAnotherConnectionIsWaitedOutNotFatal) {
  Fixture f;
  SampleWriterConfig config;
  config.commit_interval = 5ms;
  SampleWriter writer(f.path, f.trial, f.samples, f.events, config);
  Database other(f.path, Database::Mode::kReadWrite);
  other.exec("BEGIN IMMEDIATE");
  constexpr std::uint64_t kUpdates = 3000;  // > the queue's 256: it must drain while locked out
  for (std::uint64_t t = 0; t < kUpdates; ++t) push(f.samples, testing::make_sample(t));
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (writer.stats().busy_retries < 3 && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(5ms);
  EXPECT_GE(writer.stats().busy_retries, 3u);
  EXPECT_EQ(writer.stats().updates, 0u) << "nothing can be committed while the other holds the lock";
  other.exec("COMMIT");
  writer.finish({});
  EXPECT_EQ(writer.stats().updates, kUpdates);
  EXPECT_EQ(writer.stats().discarded, 0u);
  StudyDb db(f.path);
  EXPECT_EQ(db.trial(f.trial).status, TrialStatus::kComplete);
  for (int k = 0; k < 2; ++k) {
    const std::vector<StoredSample> got = db.samples(f.trial, k);
    ASSERT_EQ(got.size(), kUpdates);
    for (std::uint64_t t = 0; t < kUpdates; t += 97) expect_stored_equals(got[t], testing::make_sample(t), k);
  }
}

// The closing transaction (status, timing) waits out a held lock too.
TEST(SampleWriter, ClosingTransactionWaitsOutAHeldLock) {
  Fixture f;
  SampleWriter writer(f.path, f.trial, f.samples, f.events);
  for (std::uint64_t t = 0; t < 10; ++t) push(f.samples, testing::make_sample(t));
  Database other(f.path, Database::Mode::kReadWrite);
  other.exec("BEGIN IMMEDIATE");
  std::thread release([&] {
    std::this_thread::sleep_for(4 * kBusyWaitPerTry);
    other.exec("COMMIT");
  });
  EXPECT_NO_THROW(writer.finish({}));
  release.join();
  EXPECT_GE(writer.stats().busy_retries, 1u);
  StudyDb db(f.path);
  EXPECT_EQ(db.trial(f.trial).status, TrialStatus::kComplete);
  EXPECT_EQ(db.sample_count(f.trial, 0), 10u);
}

}  // namespace
}  // namespace hapticlab::db
