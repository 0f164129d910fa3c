#pragma once
// Published example data shared by the rank-test tests.
#include <vector>

namespace hapticlab::analysis::testing {

// R's ?friedman.test example `RoundingTimes` (Hollander & Wolfe 1973, p. 140;
// 1999 Table 7.1): times to round first base for 22 players (blocks) with
// three methods (columns: round out, narrow angle, wide angle).
inline std::vector<std::vector<double>> rounding_times() {
  return {{5.40, 5.50, 5.55}, {5.85, 5.70, 5.75}, {5.20, 5.60, 5.50}, {5.55, 5.50, 5.40},
          {5.90, 5.85, 5.70}, {5.45, 5.55, 5.60}, {5.40, 5.40, 5.35}, {5.45, 5.50, 5.35},
          {5.25, 5.15, 5.00}, {5.85, 5.80, 5.70}, {5.25, 5.20, 5.10}, {5.65, 5.55, 5.45},
          {5.60, 5.35, 5.45}, {5.05, 5.00, 4.95}, {5.50, 5.50, 5.40}, {5.45, 5.55, 5.50},
          {5.55, 5.55, 5.35}, {5.45, 5.50, 5.55}, {5.50, 5.45, 5.25}, {5.65, 5.60, 5.40},
          {5.70, 5.65, 5.55}, {6.30, 6.30, 6.25}};
}

// MATLAB's `popcorn` (Hogg & Ledolter 1987): columns are brands (Gourmet,
// National, Generic), rows 1-3 the oil popper and rows 4-6 the air popper,
// three batches each: friedman(popcorn, 3).
inline std::vector<std::vector<double>> popcorn() {
  return {{5.5, 4.5, 3.5}, {5.5, 4.5, 4.0}, {6.0, 4.0, 3.0},
          {6.5, 5.0, 4.0}, {7.0, 5.5, 5.0}, {7.0, 5.0, 4.5}};
}

}  // namespace hapticlab::analysis::testing
