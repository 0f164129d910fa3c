#pragma once
// Time-domain passivity observer (PO) and controller (PC), one DOF
// (Hannaford & Ryu 2002, "Time-domain passivity control of haptic
// interfaces", IEEE Trans. Robotics and Automation 18(1)), with the
// observer windowed as docs/engine.md explains.
//
// The axis is a one-port seen from the device: it applies force F [F] to a
// device moving at velocity v [X/s]. In one update of dt the energy it takes
// in from the hand is
//     e = −F·v·dt          (> 0: absorbed, < 0: given out)
// A passive axis never gives out more than it took in. The observer sums e
// over the last `window_s` of updates (measured dt, so any rate works):
//     E = Σ_window e
// When E < 0 the axis has generated energy; the controller adds the damping
// that dissipates exactly that much in this update,
//     α = −E / (v²·dt),  α <= max_damping,     F' = F − α·v,
// and the update's entry becomes e' = −F'·v·dt = e + α·v²·dt. Below
// |v| = min_velocity no damping is computed (α would be unbounded; the
// energy stays owed and is taken when the device moves again).
//
// Why a window: a plain sum from the start lets energy dissipated long ago
// (friction, a damper) pay for a new instability; a window of W seconds
// forgets it after W. The price: energy stored in a spring before the
// window and returned within it reads as generated, so the controller damps
// a passive spring released more slowly than W — never less passive, but
// changed (docs/engine.md has the measurements). The window is a setting.
//
// Allocation-free and noexcept: a ring buffer sized for kMaxPassivityWindow_s
// at 2 kHz.
#include <array>
#include <cstddef>

#include "core/settings/axis_settings.h"

namespace hapticlab {

class PassivityController {
 public:
  static constexpr std::size_t kCapacity = 4096;  // >= kMaxPassivityWindow_s · 2000 Hz

  void reset() noexcept;

  // The force to command instead of `force`, given this update's device
  // velocity and dt (0 < dt_s <= 1/150 s; dt_s <= 0 returns `force`).
  double step(const PassivityParams& p, double force, double velocity, double dt_s) noexcept;

  // Replaces the last step()'s force by `force` (same velocity and dt), as
  // if step() had been given it, and returns the force to command: for a
  // caller that learns a newer force after the step (the VE's force of this
  // update, Instrument::refresh_forces). Without a step since reset, or
  // called twice, it returns `force` unchanged.
  double revise(const PassivityParams& p, double force) noexcept;

  double window_energy() const noexcept { return window_energy_; }         // [F·X], after this update
  double dissipated() const noexcept { return dissipated_; }               // [F·X] by the controller since reset
  double last_damping() const noexcept { return last_damping_; }           // [F·s/X] α of the last update

 private:
  void push(double energy, double dt_s) noexcept;

  std::array<double, kCapacity> energy_{};
  std::array<double, kCapacity> dt_{};
  std::size_t head_ = 0;   // next slot to write
  std::size_t count_ = 0;  // entries in the window
  double window_energy_ = 0.0;
  double window_time_s_ = 0.0;
  double dissipated_ = 0.0;
  double last_damping_ = 0.0;
  // The state before the last step(), for revise().
  struct Before {
    std::size_t head = 0, count = 0;
    double window_energy = 0.0, window_time_s = 0.0, dissipated = 0.0;
    double overwritten_energy = 0.0, overwritten_dt = 0.0;  // the slot push() wrote
    double velocity = 0.0, dt_s = 0.0;
    bool valid = false;
  } before_;
};

}  // namespace hapticlab
