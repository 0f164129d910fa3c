// A removed sample chunk is found (db/chunk_coverage.h), not read as a
// shorter trial: a gap between chunks that no samples_missing event
// explains, and chunks that hold fewer updates than loop_timing says the
// loop ran, at the start or at the end; a gap the writer logged, and
// updates the loop could not queue, are not damage.
#include "db/chunk_coverage.h"

#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db/chunk_reader.h"
#include "db/study_db.h"
#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using ::testing::HasSubstr;

std::vector<StoredSample> samples(std::uint64_t first, std::size_t n) {
  std::vector<StoredSample> out;
  for (std::uint64_t t = first; t < first + n; ++t) {
    const LoopSample s = testing::make_sample(t);
    out.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[0]});
  }
  return out;
}

// A trial whose two instruments each hold ticks 0..999, 1000..1999, 2000..2499.
struct ThreeChunks {
  StudyDb db{":memory:"};
  std::int64_t trial = testing::make_trial(db);
  ThreeChunks() {
    for (int k = 0; k < 2; ++k) {
      db.insert_chunk(trial, k, samples(0, 1000));
      db.insert_chunk(trial, k, samples(1000, 1000));
      db.insert_chunk(trial, k, samples(2000, 500));
    }
  }
  void loop_ran(std::uint64_t periods, std::uint64_t dropped) {
    LoopTimingSummary t;
    t.count = periods;
    db.set_loop_timing(trial, t, dropped, 0);
  }
  std::vector<std::string> findings() {
    std::vector<std::string> out;
    for (const BadChunk& b : check_all_chunks(db.connection()).bad) out.push_back(describe(b));
    // The trial's own reader finds the same.
    TrialChunks chunks(db.connection(), trial);
    EXPECT_EQ(chunks.bad().size(), out.size());
    return out;
  }
};

TEST(ChunkCoverage, AnUndamagedTrialHasNoFinding) {
  ThreeChunks t;
  EXPECT_TRUE(t.findings().empty());
  t.loop_ran(2499, 0);  // 2500 updates, ticks 0..2499: all stored
  EXPECT_TRUE(t.findings().empty());
  // A trial that ended on a fault counted its last update's period but
  // published no sample of it: one short is not damage, two are.
  t.loop_ran(2500, 0);
  EXPECT_TRUE(t.findings().empty());
  t.loop_ran(2501, 0);
  EXPECT_THAT(t.findings(), ::testing::ElementsAre(HasSubstr("left instrument (0), ticks 2500..2501: not stored"),
                                                   HasSubstr("right instrument (1), ticks 2500..2501: not stored")));
}

TEST(ChunkCoverage, AChunkRemovedBetweenTwoIsAGapNoEventExplains) {
  ThreeChunks t;
  t.db.connection().exec("DELETE FROM sample_chunk WHERE instrument = 0 AND first_tick = 1000");
  EXPECT_THAT(t.findings(), ::testing::ElementsAre(
                                "trial 1, left instrument (0), ticks 1000..1999: not stored, and no samples_missing "
                                "event accounts for them (a chunk was removed)"));
  // Reading the other instrument alone finds nothing: its updates are all there.
  EXPECT_TRUE(TrialChunks(t.db.connection(), t.trial, 1).bad().empty());
  EXPECT_EQ(TrialChunks(t.db.connection(), t.trial, 0).bad().size(), 1u);
}

TEST(ChunkCoverage, AGapTheWriterLoggedIsNotDamage) {
  ThreeChunks t;
  t.db.connection().exec("DELETE FROM sample_chunk WHERE first_tick = 1000");
  t.db.add_event({t.trial, 1.0, "samples_missing", -1, 1000, "updates 1000..1999 never reached the writer"});
  t.loop_ran(2499, 1000);
  EXPECT_TRUE(t.findings().empty());
  // With updates lost, a chunk removed as well is counted, not placed.
  t.db.connection().exec("DELETE FROM sample_chunk WHERE instrument = 1 AND first_tick = 0");
  EXPECT_THAT(t.findings(), ::testing::ElementsAre(
                                "trial 1, right instrument (1), ticks 0..2499: 1000 of them not stored: the loop ran "
                                "2500 updates (ticks 0..2499) and could not queue 1000, but the chunks hold 500 (a "
                                "chunk was removed)"));
}

TEST(ChunkCoverage, TheFirstOrLastChunkRemovedIsFoundByTheLoopsCount) {
  ThreeChunks t;
  t.loop_ran(2499, 0);
  t.db.connection().exec("DELETE FROM sample_chunk WHERE instrument = 1 AND first_tick = 2000");
  t.db.connection().exec("DELETE FROM sample_chunk WHERE instrument = 0 AND first_tick = 0");
  EXPECT_THAT(t.findings(),
              ::testing::ElementsAre(
                  "trial 1, left instrument (0), ticks 0..999: not stored: the loop ran 2500 updates (ticks 0..2499) "
                  "and could not queue 0, but the chunks hold 1500 (a chunk was removed)",
                  HasSubstr("trial 1, right instrument (1), ticks 2000..2499: not stored: the loop ran 2500")));
  // Every chunk of a trial gone: all its updates are missing.
  t.db.connection().exec("DELETE FROM sample_chunk");
  EXPECT_THAT(t.findings(), ::testing::ElementsAre(HasSubstr("left instrument (0), ticks 0..2499: not stored"),
                                                   HasSubstr("right instrument (1), ticks 0..2499: not stored")));
}

TEST(ChunkCoverage, UpdatesTheLoopCouldNotQueueAtTheEndAreNotDamage) {
  ThreeChunks t;
  t.loop_ran(2599, 100);  // 2600 updates; the last 100 never queued (no event: no later sample)
  EXPECT_TRUE(t.findings().empty());
  t.loop_ran(2699, 100);  // 100 more than that are nowhere
  EXPECT_THAT(t.findings(), ::testing::ElementsAre(HasSubstr("left instrument (0), ticks 0..2699: 100 of them not stored"),
                                                   HasSubstr("right instrument (1), ticks 0..2699: 100 of them")));
}

}  // namespace
}  // namespace hapticlab::db
