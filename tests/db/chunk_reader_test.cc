// TrialChunks' two ways of reading (chunk_reader.h): next_columns() gives
// the same samples as next(), to the bit, over a trial's chunks as a file
// holds them: a chunk longer than one window, a gap between chunks, a
// channel stored once, a damaged chunk left out, and a column projection.
#include "db/chunk_reader.h"

#include <bit>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "db/study_db.h"
#include "db_test_util.h"

namespace hapticlab::db {
namespace {

std::vector<StoredSample> samples(std::uint64_t first, std::size_t n, int instrument) {
  std::vector<StoredSample> out;
  for (std::uint64_t t = first; t < first + n; ++t) {
    const LoopSample s = testing::make_sample(t);
    out.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[static_cast<std::size_t>(instrument)]});
    // Some variation where make_sample is smooth, and a channel stored once.
    out.back().value.ve_force_N[1] = std::sin(0.01 * static_cast<double>(t));
    out.back().value.displayed_force_N = {0.5, -0.25, 0.0};
  }
  return out;
}

bool same(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

TEST(TrialChunks, ColumnsAreTheSamplesOfNextToTheBit) {
  StudyDb db(":memory:");
  const std::int64_t trial = testing::make_trial(db);
  // Instrument 0: 5000 updates (two windows of kChunkWindow), then after a
  // gap 300 more (the gap logged, as the writer logs one). Instrument 1: a
  // chunk damaged, then a good one.
  db.insert_chunk(trial, 0, samples(0, 5000, 0));
  db.insert_chunk(trial, 0, samples(5100, 300, 0));
  db.add_event({trial, 5.1, "samples_missing", -1, 100, "updates 5000..5099 never reached the writer"});
  const std::int64_t damaged = db.insert_chunk(trial, 1, samples(0, 800, 1));
  db.insert_chunk(trial, 1, samples(800, 900, 1));
  testing::flip_chunk_byte(db.connection(), damaged, 40);
  ASSERT_GT(5000u, kChunkWindow);

  const ChannelSet projections[] = {kAllChannels,
                                    channel_range(kChannelT, 1) | channel_range(kChannelTipFirst, 3) |
                                        channel_range(kChannelVeForceFirst, 3)};
  for (const ChannelSet channels : projections) {
    TrialChunks rows(db.connection(), trial, -1, channels), columns(db.connection(), trial, -1, channels);
    for (int instrument = 0; instrument < 2; ++instrument) {
      std::vector<StoredSample> want;
      for (auto w = rows.next(instrument); !w.empty(); w = rows.next(instrument)) want.insert(want.end(), w.begin(), w.end());
      std::size_t k = 0;
      for (ColumnWindow w = columns.next_columns(instrument); !w.empty(); w = columns.next_columns(instrument)) {
        ASSERT_LE(w.size, kChunkWindow);
        for (std::size_t i = 0; i < w.size; ++i, ++k) {
          ASSERT_LT(k, want.size());
          ASSERT_TRUE(same(w.t_s[i], want[k].t_s)) << "instrument " << instrument << " sample " << k;
          const InstrumentSample& v = want[k].value;
          for (std::size_t j = 0; j < 3; ++j) {
            ASSERT_TRUE(same(w.channel[kChannelTipFirst + j][i], v.tip_position_m[j])) << k;
            ASSERT_TRUE(same(w.channel[kChannelVeForceFirst + j][i], v.ve_force_N[j])) << k;
            if (channels == kAllChannels) {
              ASSERT_TRUE(same(w.channel[kChannelRawFirst + j][i], v.raw_position[j])) << k;
              ASSERT_TRUE(same(w.channel[kChannelDisplayedForceFirst + j][i], v.displayed_force_N[j])) << k;
              ASSERT_TRUE(same(w.channel[kChannelJointForceFirst + j][i], v.joint_force[j])) << k;
            }
          }
        }
        // A channel outside the projection has no column.
        if (channels != kAllChannels) {
          EXPECT_EQ(w.channel[kChannelRawFirst].values, nullptr);
        }
      }
      EXPECT_EQ(k, want.size()) << "instrument " << instrument;
      EXPECT_EQ(want.size(), instrument == 0 ? 5300u : 900u);
    }
    ASSERT_EQ(columns.bad().size(), 1u);
    EXPECT_EQ(describe(columns.bad()[0]), describe(rows.bad()[0]));
  }
}

}  // namespace
}  // namespace hapticlab::db
