#include "core/engine/dof_chain.h"

#include "core/models/cogging.h"
#include "core/models/encoder.h"
#include "core/models/saturation.h"

namespace hapticlab {

double DofChain::measure(const AxisSettings& s, double position) const noexcept {
  return s.encoder.enabled ? quantize(position, s.encoder.counts_per_unit) : position;
}

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

DofOutput DofChain::step(const AxisSettings& s, double position, double ve_force, double dt_s,
                         const ButterworthCoefficients& filter) noexcept {
  // x => (x_q, v)
  const double x = measure(s, position);
  const double v = velocity_.update(x, dt_s, filter);
  last_position_ = x;
  // F_ve => F_ves
  const double f_ves = axis_ve_force(s, ve_force);

  DofOutput out;
  double motor_position = x;
  if (s.backlash.enabled && s.inertia.enabled) {
    // (mass, x_q) => x_in ; (F_ves, x_in) => forces on the mass => contact force
    const double gap = s.backlash.gap;
    const bool at_wall = backlash_.at_wall(x, gap);
    const double x_in = backlash_.limited_position(x, gap);
    const double v_in = at_wall ? v : backlash_.mass().velocity();
    LinearizedForce on_mass{f_ves, 0.0};
    if (s.cogging.enabled) on_mass += cogging_force(s.cogging, x_in);
    if (s.friction.enabled) on_mass += friction_.step(s.friction, x_in, v_in);
    // At a wall the input position follows the instrument, not the mass, so
    // those forces do not stiffen the mass.
    if (at_wall) on_mass.stiffness = 0.0;
    out.force = backlash_.step(s.inertia, s.backlash, x, v, on_mass, dt_s);
    out.position = backlash_.limited_position(x, gap);
    out.ve_coupled = true;
    motor_position = backlash_.mass().position();
  } else {
    // (F_ves, x_q, v) => F
    if (s.cogging.enabled) out.model_force += cogging_force(s.cogging, x).force;
    if (s.friction.enabled) out.model_force += friction_.step(s.friction, x, v).force;
    if (s.inertia.enabled) out.model_force += inertia_.step(s.inertia, x, v, dt_s);
    out.force = f_ves + out.model_force;
    out.position = x;
  }
  // F => F·ripple(motor position)
  if (s.cogging.enabled) {
    out.ripple = ripple_gain(s.cogging, motor_position);
    out.force *= out.ripple;
  }
  // The axis as a whole (VE force and models) against the device's motion.
  if (s.passivity.enabled) out.force = passivity_.step(s.passivity, out.force, v, dt_s);
  return out;
}

double DofChain::revise_force(const AxisSettings& s, double force) noexcept {
  return s.passivity.enabled ? passivity_.revise(s.passivity, force) : force;
}

}  // namespace hapticlab
