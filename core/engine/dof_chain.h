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

#include "core/models/backlash.h"
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
                 const ButterworthCoefficients& filter) noexcept;

  // The force to command when the last step()'s force is replaced by
  // `force` (a newer VE force, Instrument::refresh_forces): `force` itself,
  // or with passivity on, what the controller makes of it in that step.
  double revise_force(const AxisSettings& s, double force) noexcept;

 private:
  double measure(const AxisSettings& s, double position) const noexcept;

  VelocityFilter velocity_;
  Friction friction_;
  Inertia inertia_;
  Backlash backlash_;
  PassivityController passivity_;
  double last_position_ = 0.0;  // quantized, as the models saw it
};

}  // namespace hapticlab
