#pragma once
// The sign of a value as a factor: +1, −1, or 0 at exactly 0 (the models
// need 0 there — a friction or cogging force at rest has no direction).

namespace hapticlab {

constexpr double sign(double v) noexcept { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }

}  // namespace hapticlab
