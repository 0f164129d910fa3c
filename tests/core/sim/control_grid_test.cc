// ControlGrid on loop times built as running sums of dt, like the loop's
// clock: which updates act, counted by hand.
#include "core/sim/control_grid.h"

#include <vector>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

// The updates (by index) at which a 5 ms grid acts during the first 30 ms.
std::vector<int> acting_updates(double rate_Hz) {
  ControlGrid grid(0.005);
  std::vector<int> acted;
  double t_s = 0.0;
  for (int k = 0; t_s < 0.030 - 1e-9; ++k, t_s += 1.0 / rate_Hz) {
    if (!grid.due(t_s)) continue;
    grid.advance(t_s);
    acted.push_back(k);
  }
  return acted;
}

TEST(ControlGridTest, ALoopWhosePeriodDividesTheGridActsExactlyOnIt) {
  // 1 kHz: t = 0, 5, ..., 25 ms are updates 0, 5, ..., 25, although the
  // summed times land a rounding error either side of the grid points.
  EXPECT_EQ(acting_updates(1000.0), (std::vector<int>{0, 5, 10, 15, 20, 25}));
  EXPECT_EQ(acting_updates(2000.0), (std::vector<int>{0, 10, 20, 30, 40, 50}));
}

TEST(ControlGridTest, OtherwiseTheFirstUpdateAtOrAfterEachGridPoint) {
  // 500 Hz: updates at 0, 2, 4, 6, ... ms; the first at or after 0, 5, 10,
  // 15, 20, 25 ms are 0, 6, 10, 16, 20, 26 ms.
  EXPECT_EQ(acting_updates(500.0), (std::vector<int>{0, 3, 5, 8, 10, 13}));
  // 150 Hz (6.7 ms) is slower than the grid: every update acts.
  EXPECT_EQ(acting_updates(150.0), (std::vector<int>{0, 1, 2, 3, 4}));
}

}  // namespace
}  // namespace hapticlab
