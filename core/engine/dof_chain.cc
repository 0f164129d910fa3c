#include "core/engine/dof_chain.h"

namespace hapticlab {

void DofChain::reset(const AxisSettings& s, double position) noexcept {
  last_position_ = measure(s, position);
  velocity_.reset(last_position_);
  friction_.reset(last_position_);
  inertia_.reset(last_position_, 0.0);
  backlash_.reset(last_position_, 0.0);
  passivity_.reset();
}

void DofChain::on_settings_change(const AxisSettings& before,
                                  const AxisSettings& after) noexcept {
  const double x = last_position_;
  const double v = velocity_.velocity();
  const bool had_mass = before.inertia.enabled;
  const bool has_mass = after.inertia.enabled;
  if (has_mass && !had_mass) {
    inertia_.reset(x, v);
    backlash_.reset(x, v);
  }
  if (has_mass && after.backlash.enabled) {
    if (!before.backlash.enabled) backlash_.reset(x, v);
    backlash_.confine(x, after.backlash.gap);
  } else if (has_mass && before.backlash.enabled) {
    // Backlash switched off: the inertia coupling takes over from where the
    // mass is, rather than starting with the gap offset stretched in its spring.
    inertia_.reset(x, v);
  }
  if (after.passivity.enabled && !before.passivity.enabled) passivity_.reset();
  if (after.friction.enabled && !before.friction.enabled) {
    // Friction starts stuck with no force at the position it will be fed.
    const bool via_mass = has_mass && after.backlash.enabled;
    friction_.reset(via_mass ? backlash_.limited_position(x, after.backlash.gap) : x);
  }
}

void DofChain::resync(const AxisSettings& s, double position) noexcept {
  const double x = measure(s, position);
  const double shift = x - last_position_;
  velocity_.reset(x, 0.0);
  friction_.shift(shift);
  inertia_.reset(x, 0.0);
  // The mass moves with the instrument, keeping its place in the gap.
  backlash_.reset(backlash_.mass().position() + shift, 0.0);
  if (s.backlash.enabled) backlash_.confine(x, s.backlash.gap);
  passivity_.reset();  // the energy account starts again with the re-anchored models
  last_position_ = x;
}

double DofChain::revise_force(const AxisSettings& s, double force) noexcept {
  return s.passivity.enabled ? passivity_.revise(s.passivity, force) : force;
}

}  // namespace hapticlab
