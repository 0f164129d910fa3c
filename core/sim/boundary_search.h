#pragma once
// The nearest place, going out from a value whose answer is known, where a
// yes/no property (here: "the contact stays stable") changes: the stability
// map's search along one parameter (issue 19 §2).
//
// Stability need not change only once along a parameter (friction's level
// is stable, then not, then stable again in some contacts), so plain
// bisection between the two ends of a range could report a far boundary
// and miss the one next to the value a user starts from. The search
// therefore marches out from `from` towards `to` in steps that double
// (1/2^(march-1) of the way first, then twice that, ..., `to` last), stops at
// the first value whose answer differs from `from`'s, and bisects between
// it and the value before. A change closer to `from` than the first step,
// or between two probes and back again, can still be missed: the map's
// figures show every value tried.
#include <functional>

namespace hapticlab {

struct BoundarySearch {
  double lo = 0.0;       // the parameter's range, lo < hi
  double hi = 1.0;
  int steps = 12;        // bisections once a change is bracketed, 1..60
  int march = 10;        // probes on the way out, the last at the range's end, 1..30
  // Distances measured as ratios rather than differences: for a range over
  // decades (1e-6..1e-2 m). Needs lo > 0.
  bool geometric = false;
};

enum class BoundaryKind {
  kStableBelow,         // passes up to `stable`, fails from `unstable` (> stable)
  kStableAbove,         // fails up to `unstable`, passes from `stable` (> unstable)
  kStableEverywhere,    // passes all the way: no change found
  kUnstableEverywhere,  // fails all the way
};

struct Boundary {
  BoundaryKind kind = BoundaryKind::kStableEverywhere;
  // The passing and failing values nearest the change. Without a change,
  // the one that exists is `to` and the other is NaN.
  double stable = 0.0;
  double unstable = 0.0;
  int runs = 0;  // evaluations of the property
};

// Searches from `from` (inside [lo, hi], whose answer is `from_passes`)
// towards `to` (lo or hi, != from). Throws std::invalid_argument for a bad
// range, step count or start. `passes` is called in order, at most
// march + steps times; it is the caller's to make deterministic.
Boundary find_nearest_boundary(const BoundarySearch& search, double from, bool from_passes, double to,
                               const std::function<bool(double)>& passes);

}  // namespace hapticlab
