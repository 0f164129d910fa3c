#include "core/loop/spsc_queue.h"

#include <cstdint>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

TEST(SpscQueueTest, CapacityIsRoundedUpToAPowerOfTwo) {
  EXPECT_EQ(SpscQueue<int>(1).capacity(), 1u);
  EXPECT_EQ(SpscQueue<int>(3).capacity(), 4u);
  EXPECT_EQ(SpscQueue<int>(1000).capacity(), 1024u);
  EXPECT_EQ(SpscQueue<int>(1024).capacity(), 1024u);
  EXPECT_THROW(SpscQueue<int>(0), std::invalid_argument);
  EXPECT_THROW(SpscQueue<int>(SpscQueue<int>::kMaxCapacity + 1), std::invalid_argument);
}

TEST(SpscQueueTest, FifoUntilFullThenRefuses) {
  SpscQueue<int> q(3);  // 4 slots
  int out = -1;
  EXPECT_FALSE(q.try_pop(out));
  EXPECT_EQ(out, -1);
  for (int k = 0; k < 4; ++k) EXPECT_TRUE(q.try_push(k));
  EXPECT_FALSE(q.try_push(99));  // full: every slot is usable, none more
  EXPECT_EQ(q.size_approx(), 4u);
  for (int k = 0; k < 4; ++k) {
    ASSERT_TRUE(q.try_pop(out));
    EXPECT_EQ(out, k);
  }
  EXPECT_FALSE(q.try_pop(out));
  EXPECT_EQ(q.size_approx(), 0u);
}

TEST(SpscQueueTest, WrapsAroundManyTimesInOrder) {
  SpscQueue<std::uint64_t> q(4);
  std::uint64_t next_in = 0, next_out = 0, out = 0;
  for (int round = 0; round < 1000; ++round) {
    const int pushes = 1 + round % 4;
    for (int k = 0; k < pushes; ++k) ASSERT_TRUE(q.try_push(next_in++));
    while (q.try_pop(out)) ASSERT_EQ(out, next_out++);
  }
  EXPECT_EQ(next_out, next_in);
}

TEST(SpscQueueTest, PopBulkTakesWhatIsThereOldestFirst) {
  SpscQueue<int> q(8);
  for (int k = 0; k < 5; ++k) ASSERT_TRUE(q.try_push(k));
  int out[8] = {};
  EXPECT_EQ(q.pop_bulk(out, 3), 3u);
  EXPECT_EQ(out[0], 0);
  EXPECT_EQ(out[2], 2);
  for (int k = 5; k < 10; ++k) ASSERT_TRUE(q.try_push(k));  // wraps
  EXPECT_EQ(q.pop_bulk(out, 8), 7u);
  for (int k = 0; k < 7; ++k) EXPECT_EQ(out[k], 3 + k);
  EXPECT_EQ(q.pop_bulk(out, 8), 0u);
  EXPECT_EQ(q.pop_bulk(out, 0), 0u);
}

struct Sample {
  std::uint64_t seq;
  std::uint64_t check;  // a function of seq: a torn copy shows up as a mismatch
  double value;
};

std::uint64_t check_of(std::uint64_t seq) { return seq * 0x9E3779B97F4A7C15ull ^ 0xABCDEFull; }

TEST(SpscQueueTest, TwoThreadsDeliverEveryValueOnceInOrder) {
  constexpr std::uint64_t kCount = 200'000;
  SpscQueue<Sample> q(64);  // small, so the producer often finds it full
  std::uint64_t refused = 0;
  std::thread producer([&] {
    for (std::uint64_t seq = 0; seq < kCount; ++seq) {
      const Sample s{seq, check_of(seq), static_cast<double>(seq) * 0.5};
      while (!q.try_push(s)) {
        ++refused;
        std::this_thread::yield();
      }
    }
  });

  std::uint64_t expected = 0, errors = 0;
  Sample batch[16];
  while (expected < kCount) {
    // Alternate single and bulk pops to exercise both paths.
    const std::size_t n = (expected % 2 == 0) ? q.pop_bulk(batch, 16) : (q.try_pop(batch[0]) ? 1 : 0);
    if (n == 0) std::this_thread::yield();
    for (std::size_t k = 0; k < n; ++k) {
      const Sample& s = batch[k];
      if (s.seq != expected || s.check != check_of(s.seq) || s.value != static_cast<double>(s.seq) * 0.5) {
        ++errors;
      }
      ++expected;
    }
  }
  producer.join();
  EXPECT_EQ(errors, 0u);
  EXPECT_EQ(expected, kCount);
  Sample extra;
  EXPECT_FALSE(q.try_pop(extra));  // nothing delivered twice
  RecordProperty("producer_refusals", static_cast<int>(refused));
}

}  // namespace
}  // namespace hapticlab
