// The stability map's search against properties whose boundaries are known
// by construction.
#include "core/sim/boundary_search.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

TEST(BoundarySearchTest, MarchesOutInDoublingStepsThenBisects) {
  std::vector<double> tried;
  // From 0 towards 1024 over [0, 1024]: probes at 2, 4, 8, ..., 1024.
  const Boundary b = find_nearest_boundary({0.0, 1024.0, 12, 10, false}, 0.0, true, 1024.0, [&](double v) {
    tried.push_back(v);
    return v <= 37.0;
  });
  ASSERT_GE(tried.size(), 6u);
  EXPECT_EQ(std::vector<double>(tried.begin(), tried.begin() + 6), (std::vector<double>{2, 4, 8, 16, 32, 64}));
  EXPECT_EQ(b.kind, BoundaryKind::kStableBelow);
  EXPECT_LE(b.stable, 37.0);
  EXPECT_GT(b.unstable, 37.0);
  // 12 halvings of the bracket [32, 64].
  EXPECT_NEAR(b.unstable - b.stable, 32.0 / 4096.0, 1e-12);
  EXPECT_EQ(b.runs, 6 + 12);
  EXPECT_EQ(static_cast<int>(tried.size()), b.runs);
}

// Stable from 0.45 up to 0.7, unstable to 3, stable again beyond: the
// search from 0.45 reports the change at 0.7, not the one at 3 that
// bisecting between the range's ends would find.
TEST(BoundarySearchTest, FindsTheChangeNearestTheStartWhenStabilityChangesTwice) {
  auto island = [](double v) { return v <= 0.7 || v >= 3.0; };
  const Boundary b = find_nearest_boundary({0.0, 50.0, 16, 10, false}, 0.45, true, 50.0, island);
  EXPECT_EQ(b.kind, BoundaryKind::kStableBelow);
  EXPECT_NEAR(b.stable, 0.7, 1e-3);
  EXPECT_GT(b.unstable, 0.7);
}

TEST(BoundarySearchTest, GeometricStepsAreRatios) {
  std::vector<double> tried;
  const Boundary b = find_nearest_boundary({1e-6, 1.0, 10, 3, true}, 1e-2, true, 1e-6, [&](double v) {
    tried.push_back(v);
    return v >= 3.3e-4;
  });
  // Towards 1e-6 (four decades): a quarter of the way (1e-3), half (1e-4).
  ASSERT_GE(tried.size(), 2u);
  EXPECT_NEAR(tried[0], 1e-3, 1e-15);
  EXPECT_NEAR(tried[1], 1e-4, 1e-16);
  EXPECT_EQ(b.kind, BoundaryKind::kStableAbove);
  EXPECT_GE(b.stable, 3.3e-4);
  EXPECT_LT(b.unstable, 3.3e-4);
  // The ratio 10 after 10 halvings of its logarithm.
  EXPECT_NEAR(std::log(b.stable / b.unstable), std::log(10.0) / 1024.0, 1e-9);
}

TEST(BoundarySearchTest, FromAnUnstableStartFindsTheNearestStableValue) {
  const Boundary b = find_nearest_boundary({0.0, 2.0, 20, 10, false}, 0.1, false, 2.0, [](double v) { return v >= 0.25; });
  EXPECT_EQ(b.kind, BoundaryKind::kStableAbove);
  EXPECT_GE(b.stable, 0.25);
  EXPECT_LT(b.unstable, 0.25);
  EXPECT_LT(b.stable - b.unstable, 1e-5);
}

TEST(BoundarySearchTest, WithoutAChangeTheMarchEndsAtTheEnd) {
  std::vector<double> tried;
  const Boundary all = find_nearest_boundary({1.0, 5.0, 12, 3, false}, 1.0, true, 5.0, [&](double v) {
    tried.push_back(v);
    return true;
  });
  EXPECT_EQ(all.kind, BoundaryKind::kStableEverywhere);
  EXPECT_EQ(all.stable, 5.0);
  EXPECT_TRUE(std::isnan(all.unstable));
  EXPECT_EQ(tried, (std::vector<double>{2.0, 3.0, 5.0}));
  const Boundary none = find_nearest_boundary({1.0, 5.0, 12, 3, false}, 5.0, false, 1.0, [](double) { return false; });
  EXPECT_EQ(none.kind, BoundaryKind::kUnstableEverywhere);
  EXPECT_EQ(none.unstable, 1.0);
  EXPECT_TRUE(std::isnan(none.stable));
  EXPECT_EQ(none.runs, 3);
}

TEST(BoundarySearchTest, StopsWhenTheBracketCannotBeHalvedAgain) {
  const Boundary b = find_nearest_boundary({0.0, 1.0, 60, 1, false}, 0.0, true, 1.0, [](double v) { return v <= 0.5; });
  EXPECT_LT(b.runs, 1 + 60);
  EXPECT_EQ(b.stable, 0.5);
  EXPECT_EQ(b.unstable, std::nextafter(0.5, 1.0));
}

TEST(BoundarySearchTest, BadRangesStepsAndStartsAreRefused) {
  auto any = [](double) { return true; };
  auto message = [&](const BoundarySearch& s, double from, double to) -> std::string {
    try {
      find_nearest_boundary(s, from, true, to, any);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_EQ(message({2.0, 1.0, 12, 10, false}, 1.5, 2.0),
            "boundary search: the range is 2..1, but must be finite with lo < hi");
  EXPECT_EQ(message({0.0, 1.0, 0, 10, false}, 0.5, 1.0), "boundary search: steps is 0, but must be >= 1 and <= 60");
  EXPECT_EQ(message({0.0, 1.0, 12, 31, false}, 0.5, 1.0), "boundary search: march is 31, but must be >= 1 and <= 30");
  EXPECT_EQ(message({0.0, 1.0, 12, 10, true}, 0.5, 1.0), "boundary search: a geometric range needs lo > 0, but lo is 0");
  EXPECT_EQ(message({0.0, 1.0, 12, 10, false}, 1.5, 1.0), "boundary search: the start 1.5 is outside the range 0..1");
  EXPECT_EQ(message({0.0, 1.0, 12, 10, false}, 0.5, 0.7),
            "boundary search: the end 0.7 must be lo or hi and differ from the start 0.5");
}

}  // namespace
}  // namespace hapticlab
