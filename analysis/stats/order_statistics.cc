#include "analysis/stats/order_statistics.h"

#include <algorithm>
#include <bit>
#include <cstdint>
#include <vector>

namespace hapticlab::analysis {
namespace {

// Puts the order statistics at ranks[lo, hi) (ascending, absolute indices)
// in place: nth_element on the middle rank, then each side with its ranks.
// A rank next to one just placed (a percentile between two order
// statistics asks for both) is the largest of what lies below it, or the
// smallest of what lies above: one pass, not another nth_element.
void select_ranks(std::vector<double>::iterator base, std::size_t first, std::size_t last,
                  std::span<const std::size_t> ranks, std::size_t lo, std::size_t hi) {
  const auto at = [&](std::size_t i) { return base + static_cast<std::ptrdiff_t>(i); };
  while (lo < hi && first < last) {
    const std::size_t mid = lo + (hi - lo) / 2;
    const std::size_t r = ranks[mid];
    std::nth_element(at(first), at(r), at(last));
    std::size_t left_end = r, left_hi = mid;
    if (left_hi > lo && ranks[left_hi - 1] + 1 == r) {
      std::iter_swap(std::max_element(at(first), at(r)), at(r - 1));
      --left_end;
      --left_hi;
    }
    select_ranks(base, first, left_end, ranks, lo, left_hi);
    first = r + 1;
    lo = mid + 1;
    if (lo < hi && ranks[lo] == first && first < last) {
      std::iter_swap(std::min_element(at(first), at(last)), at(first));
      ++first;
      ++lo;
    }
  }
}

std::vector<double> by_nth_element(std::vector<double>& values, std::span<const std::size_t> ranks) {
  select_ranks(values.begin(), 0, values.size(), ranks, 0, ranks.size());
  std::vector<double> out;
  out.reserve(ranks.size());
  for (std::size_t r : ranks) out.push_back(values[r]);
  return out;
}

// Below this many values nth_element alone is as fast (the counts' table is
// 256 KiB).
constexpr std::size_t kMinBucketed = 4096;
constexpr int kKeyShift = 48;  // sign, 11 exponent bits, 4 mantissa bits
constexpr std::size_t kBuckets = std::size_t{1} << (64 - kKeyShift);
constexpr std::uint32_t kWanted = 0x8000'0000u;  // a count's top bit: "a wanted bucket", the rest its slot

std::uint32_t key_of(double v) { return static_cast<std::uint32_t>(std::bit_cast<std::uint64_t>(v) >> kKeyShift); }

// One table per thread, zero between calls (each call clears what it used).
std::vector<std::uint32_t>& bucket_table() {
  thread_local std::vector<std::uint32_t> table(kBuckets, 0);
  return table;
}

// A bucket that holds wanted ranks.
struct Wanted {
  std::uint32_t key;
  std::size_t below;  // values in lower buckets
  std::size_t size;   // values in this bucket
  std::size_t offset = 0;
};
struct Located {
  std::vector<Wanted> wanted;            // ascending
  std::vector<std::size_t> slot_of_rank;  // ranks[i] is in wanted[slot_of_rank[i]]
};

// Which bucket holds each rank, and how many values lie in buckets below it.
Located locate(const std::vector<std::uint32_t>& count, std::uint32_t low, std::uint32_t high,
               std::span<const std::size_t> ranks) {
  Located out;
  out.slot_of_rank.resize(ranks.size());
  std::size_t below = 0, next = 0;
  for (std::uint32_t key = low; key <= high && next < ranks.size(); ++key) {
    const std::size_t c = count[key];
    if (ranks[next] >= below + c) {
      below += c;
      continue;
    }
    out.wanted.push_back({key, below, c});
    while (next < ranks.size() && ranks[next] < below + c) out.slot_of_rank[next++] = out.wanted.size() - 1;
    below += c;
  }
  return out;
}

}  // namespace

std::vector<double> order_statistics(std::vector<double>& values, std::span<const std::size_t> ranks) {
  const std::size_t n = values.size();
  // (A count's top bit marks a wanted bucket, so fewer than 2^31 values.)
  if (n < kMinBucketed || n >= kWanted || ranks.empty()) {
    return by_nth_element(values, ranks);
  }

  std::vector<std::uint32_t>& count = bucket_table();
  std::uint32_t low = static_cast<std::uint32_t>(kBuckets - 1), high = 0;
  std::uint64_t any_sign = 0;
  for (double v : values) {
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(v);
    any_sign |= bits;
    const auto key = static_cast<std::uint32_t>(bits >> kKeyShift);
    ++count[key];
    low = std::min(low, key);
    high = std::max(high, key);
  }
  const auto clear = [&] { std::fill(count.begin() + low, count.begin() + high + 1, 0u); };
  if ((any_sign >> 63) != 0) {  // a negative value or −0.0: bits no longer order the values
    clear();
    return by_nth_element(values, ranks);
  }

  Located located = locate(count, low, high, ranks);
  std::vector<Wanted>& wanted = located.wanted;
  const std::vector<std::size_t>& slot_of_rank = located.slot_of_rank;
  std::size_t gathered = 0;
  for (std::size_t s = 0; s < wanted.size(); ++s) {
    wanted[s].offset = gathered;
    gathered += wanted[s].size;
    count[wanted[s].key] = kWanted | static_cast<std::uint32_t>(s);
  }

  // The wanted buckets' values, bucket after bucket.
  std::vector<double> picked(gathered);
  std::vector<std::size_t> fill(wanted.size());
  for (std::size_t s = 0; s < wanted.size(); ++s) fill[s] = wanted[s].offset;
  for (double v : values) {
    const std::uint32_t c = count[key_of(v)];
    if ((c & kWanted) != 0) picked[fill[c & ~kWanted]++] = v;
  }
  clear();

  // Within a bucket, the rank less the values below it; each bucket's ranks
  // selected in its own stretch of `picked`.
  std::vector<std::size_t> local(ranks.size());
  for (std::size_t i = 0; i < ranks.size(); ++i) {
    const Wanted& w = wanted[slot_of_rank[i]];
    local[i] = w.offset + (ranks[i] - w.below);
  }
  for (std::size_t i = 0; i < ranks.size();) {
    std::size_t j = i;
    while (j < ranks.size() && slot_of_rank[j] == slot_of_rank[i]) ++j;
    const Wanted& w = wanted[slot_of_rank[i]];
    select_ranks(picked.begin(), w.offset, w.offset + w.size, std::span(local).subspan(0, j), i, j);
    i = j;
  }
  std::vector<double> out;
  out.reserve(ranks.size());
  for (std::size_t i = 0; i < ranks.size(); ++i) out.push_back(picked[local[i]]);
  return out;
}

}  // namespace hapticlab::analysis
