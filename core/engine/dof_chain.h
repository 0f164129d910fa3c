#pragma once
// The degradation chain of one DOF (thesis 2.2.6.1, Fig. 2-11 and 2-12).
//
//   (x measured, F_ve on this axis, dt)
//     encoder      x  => x_q                       (quantized position)
//     velocity     x_q => v                        (difference + 70 Hz Butterworth)
//     saturation   F_ve => F_ves                   (clip of the VE force on this axis)
//     without backlash (Fig. 2-12):
//       F = F_ves + cogging(x_q) + friction(x_q, v) + inertia(x_q, v)
//       x_ve = x_q
//     with backlash (Fig. 2-11):
//       x_in = mass position limited to x_q ± gap/2
//       mass <= F_ves + cogging(x_in) + friction(x_in) ; F = gap contact force
//       x_ve = x_in
//     ripple       F => F·(1 + r·sin(...))         (of the motor-side position)
//     passivity    F => F − α·v  while the axis gave out energy over its window
//   => (F commanded on this axis, x_ve sent to the VE)
//
// Everything here is allocation-free and noexcept; parameters are validated
// when settings are loaded, not here.
//
// step() is inline (the instrument calls it three times per update), and
// what depends on the settings alone comes precomputed in AxisTerms.

#include "core/models/backlash.h"
#include "core/models/cogging.h"
#include "core/models/encoder.h"
#include "core/models/friction.h"
#include "core/models/inertia.h"
#include "core/models/passivity.h"
#include "core/models/saturation.h"
#include "core/models/velocity_filter.h"
#include "core/settings/axis_settings.h"

namespace hapticlab {

struct DofOutput {
  double force = 0.0;     // [F] commanded on this axis, before the device limit
  double position = 0.0;  // [X] degraded position for the VE
  // How `force` depends on this step's (saturated) VE force F_ves, so that a
  // newer VE force can replace it after the step (Instrument::refresh_forces):
  // force = (F_ves + model_force)·ripple, up to rounding. Not so when
  // ve_coupled: with backlash and inertia F_ves moved the mass, so another
  // F_ves would have changed the state, not just the force.
  double model_force = 0.0;  // [F] cogging + friction + inertia
  double ripple = 1.0;       // cogging ripple gain
  bool ve_coupled = false;
};

// F_ve => F_ves: the VE force on this axis after the axis' saturation.
inline double axis_ve_force(const AxisSettings& s, double ve_force) noexcept {
  return s.saturation.enabled ? saturate(ve_force, s.saturation.level) : ve_force;
}

// What a chain derives from its AxisSettings alone, computed once per
// settings change instead of every update; the same values, bit for bit, as
// the models compute from the settings themselves.
struct AxisTerms {
  AxisTerms() = default;
  explicit AxisTerms(const AxisSettings& s) noexcept
      : cogging(s.cogging.enabled ? CoggingTerms(s.cogging) : CoggingTerms()),
        friction_stiffness(s.friction.enabled ? Friction::presliding_stiffness(s.friction) : 0.0),
        coupling_damping(s.inertia.enabled ? hapticlab::coupling_damping(s.inertia) : 0.0),
        karnopp(Backlash::karnopp(s.backlash)) {}

  CoggingTerms cogging;
  double friction_stiffness = 0.0;  // [F/X] Friction::presliding_stiffness
  double coupling_damping = 0.0;    // [F·s/X] B = ζ·2·sqrt(K·m) of the inertia coupling
  KarnoppFriction karnopp;          // on the free mass in the backlash gap
};

class DofChain {
 public:
  // Puts every model in its neutral state at `position`, at rest.
  void reset(const AxisSettings& s, double position) noexcept;

  // Called between two updates when the settings change: models that are
  // switched on start neutral (no force jump), the mass is kept in a changed gap.
  void on_settings_change(const AxisSettings& before, const AxisSettings& after) noexcept;

  // Re-anchors the dynamic states at a new measured position after a stall or
  // a fault, keeping position-independent forces and dropping stored energy.
  void resync(const AxisSettings& s, double position) noexcept;

  // One update of dt_s (0 <= dt_s <= 1/150 s); `filter` holds the Butterworth
  // coefficients for this dt.
  DofOutput step(const AxisSettings& s, double position, double ve_force, double dt_s,
                 const ButterworthCoefficients& filter) noexcept {
    return step(s, AxisTerms(s), position, ve_force, dt_s, filter);
  }
  // The same with `terms` = AxisTerms(s) computed beforehand. Always inlined:
  // returned through memory, its output cost more than some of its models.
  [[gnu::always_inline]] DofOutput step(const AxisSettings& s, const AxisTerms& terms, double position, double ve_force,
                 double dt_s, const ButterworthCoefficients& filter) noexcept;

  // The force to command when the last step()'s force is replaced by
  // `force` (a newer VE force, Instrument::refresh_forces): `force` itself,
  // or with passivity on, what the controller makes of it in that step.
  double revise_force(const AxisSettings& s, double force) noexcept;

 private:
  static double measure(const AxisSettings& s, double position) noexcept {
    return s.encoder.enabled ? quantize(position, s.encoder.counts_per_unit) : position;
  }

  VelocityFilter velocity_;
  Friction friction_;
  Inertia inertia_;
  Backlash backlash_;
  double last_position_ = 0.0;  // quantized, as the models saw it
  // Their angles repeat while the motor-side position does (a mass stuck in
  // its gap, a device at rest).
  SinCosMemo cogging_angle_;
  SinMemo ripple_angle_;
  // Last: its 64 KiB window would put the state above on other pages.
  PassivityController passivity_;
};

inline DofOutput DofChain::step(const AxisSettings& s, const AxisTerms& terms, double position,
                                double ve_force, double dt_s,
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
    const double x_in = backlash_.limited_position(x, gap);
    const bool at_wall = x_in != backlash_.mass().position();  // Backlash::at_wall
    const double v_in = at_wall ? v : backlash_.mass().velocity();
    LinearizedForce on_mass{f_ves, 0.0};
    if (s.cogging.enabled) {
      // At a wall the stiffness is dropped below, so the cosine is not needed.
      const double angle = cogging_angle(s.cogging, terms.cogging, x_in);
      on_mass += at_wall ? LinearizedForce{cogging_force_from_sin(s.cogging, cogging_angle_.sin(angle)), 0.0}
                         : cogging_force(s.cogging, terms.cogging, cogging_angle_(angle));
    }
    if (s.friction.enabled) on_mass += friction_.step(s.friction, terms.friction_stiffness, x_in, v_in);
    // At a wall the input position follows the instrument, not the mass, so
    // those forces do not stiffen the mass.
    if (at_wall) on_mass.stiffness = 0.0;
    out.force = backlash_.step(s.inertia, terms.coupling_damping, terms.karnopp, s.backlash, x, v,
                               on_mass, dt_s);
    out.position = backlash_.limited_position(x, gap);
    out.ve_coupled = true;
    motor_position = backlash_.mass().position();
  } else {
    // (F_ves, x_q, v) => F
    if (s.cogging.enabled) {
      // Only the force: the stiffness matters to a mass, and there is none here.
      out.model_force +=
          cogging_force_from_sin(s.cogging, cogging_angle_.sin(cogging_angle(s.cogging, terms.cogging, x)));
    }
    if (s.friction.enabled) out.model_force += friction_.step(s.friction, terms.friction_stiffness, x, v).force;
    if (s.inertia.enabled) out.model_force += inertia_.step(s.inertia, terms.coupling_damping, x, v, dt_s);
    out.force = f_ves + out.model_force;
    out.position = x;
  }
  // F => F·ripple(motor position)
  if (s.cogging.enabled) {
    out.ripple = s.cogging.ripple_fraction == 0.0
                     ? 1.0
                     : ripple_gain_from_sin(s.cogging, ripple_angle_(ripple_angle(s.cogging, motor_position)));
    out.force *= out.ripple;
  }
  // The axis as a whole (VE force and models) against the device's motion.
  if (s.passivity.enabled) out.force = passivity_.step(s.passivity, out.force, v, dt_s);
  return out;
}

}  // namespace hapticlab
