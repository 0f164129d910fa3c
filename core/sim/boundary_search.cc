#include "core/sim/boundary_search.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/common/csv_format.h"

namespace hapticlab {
namespace {

void check(const BoundarySearch& s, double from, double to) {
  auto bad = [](const std::string& what) { throw std::invalid_argument("boundary search: " + what); };
  if (!(std::isfinite(s.lo) && std::isfinite(s.hi) && s.lo < s.hi))
    bad("the range is " + format_number(s.lo) + ".." + format_number(s.hi) + ", but must be finite with lo < hi");
  if (s.steps < 1 || s.steps > 60) bad("steps is " + std::to_string(s.steps) + ", but must be >= 1 and <= 60");
  if (s.march < 1 || s.march > 30) bad("march is " + std::to_string(s.march) + ", but must be >= 1 and <= 30");
  if (s.geometric && !(s.lo > 0.0)) bad("a geometric range needs lo > 0, but lo is " + format_number(s.lo));
  if (!(from >= s.lo && from <= s.hi))
    bad("the start " + format_number(from) + " is outside the range " + format_number(s.lo) + ".." +
        format_number(s.hi));
  if (!((to == s.lo || to == s.hi) && to != from))
    bad("the end " + format_number(to) + " must be lo or hi and differ from the start " + format_number(from));
}

// The point a fraction t of the way from a to b.
double between(double a, double b, double t, bool geometric) {
  return geometric ? a * std::pow(b / a, t) : a + (b - a) * t;
}

}  // namespace

Boundary find_nearest_boundary(const BoundarySearch& s, double from, bool from_passes, double to,
                               const std::function<bool(double)>& passes) {
  check(s, from, to);
  Boundary b;
  double same = from;  // the farthest value known to answer as `from` does
  double changed = std::numeric_limits<double>::quiet_NaN();
  for (int k = 1; k <= s.march; ++k) {
    const double v = k == s.march ? to : between(from, to, std::ldexp(1.0, k - s.march), s.geometric);
    ++b.runs;
    if (passes(v) != from_passes) {
      changed = v;
      break;
    }
    same = v;
  }
  if (std::isnan(changed)) {
    b.kind = from_passes ? BoundaryKind::kStableEverywhere : BoundaryKind::kUnstableEverywhere;
    b.stable = from_passes ? to : std::numeric_limits<double>::quiet_NaN();
    b.unstable = from_passes ? std::numeric_limits<double>::quiet_NaN() : to;
    return b;
  }
  for (int i = 0; i < s.steps; ++i) {
    const double mid = s.geometric ? std::sqrt(same * changed) : 0.5 * (same + changed);
    // Exhausted at double precision: more steps change nothing.
    if (mid == same || mid == changed) break;
    ++b.runs;
    (passes(mid) == from_passes ? same : changed) = mid;
  }
  b.stable = from_passes ? same : changed;
  b.unstable = from_passes ? changed : same;
  b.kind = b.stable < b.unstable ? BoundaryKind::kStableBelow : BoundaryKind::kStableAbove;
  return b;
}

}  // namespace hapticlab
