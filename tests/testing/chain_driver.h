#pragma once
// Drives one DofChain along a prescribed position x(t) with the dt sequence
// of a rate case, the way the instrument does: measured dt, Butterworth
// coefficients for that dt.

#include "core/engine/dof_chain.h"
#include "testing/rates.h"

namespace hapticlab::testing {

struct ChainStep {
  double t_s;
  double dt_s;
  double x;
  DofOutput out;
};

// position(t) -> x; ve_force(t) -> F_ve on the axis; on_step(const ChainStep&).
// The chain starts at rest at position(0).
template <typename Position, typename VeForce, typename OnStep>
void drive_chain(const AxisSettings& s, const RateCase& rate, double duration_s,
                 Position position, VeForce ve_force, OnStep on_step) {
  DofChain chain;
  chain.reset(s, position(0.0));
  DtSource dts(rate);
  for (double t = 0.0; t < duration_s;) {
    const double dt = dts.next();
    t += dt;
    const double x = position(t);
    const DofOutput out =
        chain.step(s, x, ve_force(t), dt, butterworth_lowpass_1st(kVelocityCutoff_Hz, dt));
    on_step(ChainStep{t, dt, x, out});
  }
}

inline auto no_force() {
  return [](double) { return 0.0; };
}
inline auto constant_force(double f) {
  return [f](double) { return f; };
}

}  // namespace hapticlab::testing
