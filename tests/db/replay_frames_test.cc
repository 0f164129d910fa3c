#include "db/replay_frames.h"

#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/common/clock.h"
#include "core/sim/trial_runner.h"
#include "db/sample_writer.h"
#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

// What the database keeps of a device reading: the nearest float32 (the
// codec's documented precision), which the replay then reproduces exactly.
DeviceJoints stored(const std::array<double, 5>& raw) {
  DeviceJoints q{};
  for (std::size_t j = 0; j < 5; ++j) q[j] = double{to_stored_float(raw[j])};
  return q;
}

// A short simulated trial (virtual clock), logged through the SampleWriter
// as the session runner does; `sent` keeps what the loop produced.
std::int64_t record_sim_trial(const std::filesystem::path& path, std::vector<LoopSample>& sent) {
  std::int64_t trial = 0;
  {
    StudyDb db(path);
    trial = testing::make_trial(db);
  }
  SpscQueue<LoopSample> samples(1 << 12);
  SpscQueue<TaskEvent> events(1 << 8);
  SampleWriter writer(path, trial, samples, events);
  SimTrialConfig config;
  config.task = TaskKind::kDissection;
  config.max_duration_s = 0.4;
  config.stop_when_complete = false;
  SimTrialSink sink;
  sink.on_sample = [&](const LoopSample& s) {
    sent.push_back(s);
    while (!samples.try_push(s)) std::this_thread::yield();
  };
  const SimTrialResult result = run_sim_trial(config, sink);
  TrialOutcome outcome;
  outcome.timing = result.timing;
  writer.finish(outcome);
  return trial;
}

TEST(ReplayFrames, ReproduceTheStoredRawPositionsOfBothInstruments) {
  testing::TempDir dir;
  const auto path = dir.file("replay.db");
  std::vector<LoopSample> sent;
  const std::int64_t trial = record_sim_trial(path, sent);
  ASSERT_GT(sent.size(), 300u);

  StudyDb db(path);
  const std::vector<ReplayFrame> frames = load_replay_frames(db, trial);
  ASSERT_EQ(frames.size(), sent.size());
  const std::vector<StoredSample> left = db.samples(trial, 0), right = db.samples(trial, 1);
  bool moved = false;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].t_s, sent[i].t_s) << "frame " << i;
    EXPECT_EQ(frames[i].position[0], left[i].value.raw_position) << "frame " << i;
    EXPECT_EQ(frames[i].position[1], right[i].value.raw_position) << "frame " << i;
    EXPECT_EQ(frames[i].position[0], stored(sent[i].instrument[0].raw_position)) << "frame " << i;
    EXPECT_EQ(frames[i].position[1], stored(sent[i].instrument[1].raw_position)) << "frame " << i;
    moved = moved || frames[i].position[1] != frames[0].position[1];
  }
  EXPECT_TRUE(moved) << "the simulated hand moved the right instrument";

  // A replay device plays them back: at each frame's time it reads exactly
  // that frame.
  ReplayDevice device(frames);
  VirtualClock clock;
  clock.sleep_until(frames.front().t_s);
  ASSERT_EQ(device.configure({}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  for (std::size_t i = 0; i < frames.size(); i += 37) {
    clock.sleep_until(frames[i].t_s);
    DeviceReading reading;
    ASSERT_EQ(device.read(reading), DeviceStatus::kOk);
    EXPECT_EQ(reading.position, frames[i].position) << "frame " << i;
  }
}

TEST(ReplayFrames, AnInstrumentMissingTicksHoldsItsPosition) {
  StudyDb db(":memory:");
  const std::int64_t trial = testing::make_trial(db);
  std::vector<StoredSample> left, right;
  for (std::uint64_t t = 0; t < 10; ++t) {
    const LoopSample s = testing::make_sample(t);
    left.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[0]});
    if (t >= 3 && t < 6) right.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[1]});
  }
  db.insert_chunk(trial, 0, left);
  db.insert_chunk(trial, 1, right);
  const std::vector<ReplayFrame> frames = load_replay_frames(db, trial);
  ASSERT_EQ(frames.size(), 10u);
  const std::vector<StoredSample> r = db.samples(trial, 1);
  for (std::size_t i = 0; i < 10; ++i) {
    EXPECT_EQ(frames[i].t_s, left[i].t_s);
    // Before its first update: its first position; after its last: its last.
    const std::size_t k = i < 3 ? 0 : (i < 6 ? i - 3 : 2);
    EXPECT_EQ(frames[i].position[1], r[k].value.raw_position) << "frame " << i;
  }
}

TEST(ReplayFrames, ATrialWithoutSamplesIsRefusedNamingIt) {
  StudyDb db(":memory:");
  const std::int64_t trial = testing::make_trial(db, /*start=*/false);
  try {
    load_replay_frames(db, trial);
    FAIL();
  } catch (const DbError& e) {
    EXPECT_THAT(e.what(), HasSubstr("trial " + std::to_string(trial) + " has no stored samples"));
  }
  EXPECT_THROW(load_replay_frames(db, trial + 100), DbError);
}

}  // namespace
// A damaged chunk is refused by name, not replayed as a held position.
TEST(ReplayFrames, ADamagedChunkIsRefusedNamingItsTrialInstrumentAndTicks) {
  StudyDb db(":memory:");
  const std::int64_t trial = testing::make_trial(db);
  for (int k = 0; k < 2; ++k) {
    std::vector<StoredSample> samples;
    for (std::uint64_t t = 0; t < 10; ++t) {
      const LoopSample s = testing::make_sample(t);
      samples.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[static_cast<std::size_t>(k)]});
    }
    db.insert_chunk(trial, k, samples);
  }
  ASSERT_EQ(load_replay_frames(db, trial).size(), 10u);
  testing::flip_chunk_byte(db.connection(), 2, 12);  // the right instrument's chunk
  EXPECT_THAT([&] { load_replay_frames(db, trial); },
              ::testing::ThrowsMessage<DbError>(
                  AllOf(HasSubstr("trial " + std::to_string(trial) + " cannot be replayed"),
                        HasSubstr("right instrument (1), ticks 0..9: checksum mismatch"))));
}

}  // namespace hapticlab::db
