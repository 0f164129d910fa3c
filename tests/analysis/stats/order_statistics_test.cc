#include "analysis/stats/order_statistics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace hapticlab::analysis {
namespace {

struct Lcg {
  std::uint64_t state;
  double unit() {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) * 0x1.0p-53;
  }
  std::size_t below(std::size_t n) { return static_cast<std::size_t>(unit() * static_cast<double>(n)); }
};

// Compared by bits: an order statistic must be the very element a sort puts
// there (−0.0 and +0.0 differ).
void expect_as_sorted(std::vector<double> values, const std::vector<std::size_t>& ranks, const std::string& what) {
  std::vector<double> sorted = values;
  std::stable_sort(sorted.begin(), sorted.end());
  const std::vector<double> got = order_statistics(values, ranks);
  ASSERT_EQ(got.size(), ranks.size()) << what;
  for (std::size_t i = 0; i < ranks.size(); ++i) {
    const double want = sorted[ranks[i]];
    if (want == 0.0 && std::signbit(want) != std::signbit(got[i])) {
      continue;  // −0.0 and +0.0 compare equal: a sort may put either first
    }
    ASSERT_EQ(std::bit_cast<std::uint64_t>(got[i]), std::bit_cast<std::uint64_t>(want))
        << what << ": rank " << ranks[i] << " of " << values.size() << " gave " << got[i] << ", a sort " << want;
  }
}

std::vector<std::size_t> random_ranks(Lcg& rng, std::size_t n, std::size_t k) {
  std::vector<std::size_t> ranks;
  while (ranks.size() < k) {
    const std::size_t r = rng.below(n);
    ranks.push_back(r);
    if (r + 1 < n && rng.unit() < 0.5) ranks.push_back(r + 1);  // a percentile between two ranks
  }
  std::sort(ranks.begin(), ranks.end());
  ranks.erase(std::unique(ranks.begin(), ranks.end()), ranks.end());
  return ranks;
}

// Samples of the shapes analyze meets (force magnitudes spread over many
// binades, speeds with exact zeros, heavy ties, one value only) and the ones
// that must take the nth_element path (a negative value, −0.0), each large
// enough for the bucket path, against a full sort.
TEST(OrderStatisticsTest, EveryRankIsWhatASortPutsThere) {
  Lcg rng{2026};
  struct Shape {
    const char* name;
    double (*draw)(Lcg&);
  };
  const Shape shapes[] = {
      {"uniform", [](Lcg& r) { return r.unit(); }},
      {"many binades", [](Lcg& r) { return std::exp(-30.0 * r.unit()) * 40.0; }},
      {"zeros and small", [](Lcg& r) { return r.unit() < 0.3 ? 0.0 : r.unit() * 1e-3; }},
      {"ties", [](Lcg& r) { return std::round(r.unit() * 12.0) / 4.0; }},
      {"one bucket", [](Lcg& r) { return 1.0 + r.unit() * 0.01; }},
      {"all equal", [](Lcg&) { return 0.125; }},
      {"subnormal and huge", [](Lcg& r) {
         return r.unit() < 0.5 ? std::numeric_limits<double>::denorm_min() * (1.0 + r.below(1000))
                               : std::numeric_limits<double>::max() * r.unit();
       }},
      {"signed", [](Lcg& r) { return r.unit() - 0.5; }},
  };
  for (const Shape& shape : shapes) {
    for (const std::size_t n : {4095u, 4096u, 5000u, 40000u}) {
      std::vector<double> values(n);
      for (double& v : values) v = shape.draw(rng);
      for (const std::size_t k : {1u, 2u, 4u, 9u, 16u, 40u, 203u}) {
        expect_as_sorted(values, random_ranks(rng, n, k), std::string(shape.name) + " n " + std::to_string(n));
      }
      expect_as_sorted(values, {0, 1, n / 2, n - 2, n - 1}, std::string(shape.name) + " ends");
    }
  }
  // One −0.0 among positive values: the bits no longer order the sample.
  std::vector<double> values(6000);
  for (double& v : values) v = rng.unit();
  values[17] = -0.0;
  values[18] = 0.0;
  expect_as_sorted(values, {0, 1, 2, 3000, 5999}, "a -0.0");
}

// The buckets' counts are cleared after every call: a second call on another
// sample must not see the first's.
TEST(OrderStatisticsTest, CallsDoNotSeeEachOther) {
  Lcg rng{7};
  for (int round = 0; round < 20; ++round) {
    std::vector<double> values(5000 + rng.below(3000));
    const double scale = std::exp(40.0 * (rng.unit() - 0.5));
    for (double& v : values) v = scale * rng.unit();
    expect_as_sorted(values, random_ranks(rng, values.size(), 4), "round " + std::to_string(round));
  }
}

}  // namespace
}  // namespace hapticlab::analysis
