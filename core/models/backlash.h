#pragma once
// Backlash, one DOF (thesis 2.2.2, eq. 2.7–2.8, Fig. 2-4 and 2-11). The
// virtual mass of the inertia model (the lumped motor and transmission) sits
// in a gap of width d around the instrument. While the instrument is inside
// the gap no force is felt. When it passes a gap wall the virtual coupling
// (K, B of the inertia settings) engages at that wall, p_vc = x_vm ± d/2:
//
//   F_hi = −(K·(x_hi − p_vc) + B·(v_hi − v_vm))   only while it pushes (unilateral)
//
// The VE, cogging and friction forces act on the mass (Fig. 2-11), and their
// position input is the mass position limited to within d/2 of the
// instrument: that position is also what the VE is shown, so the visual gap
// walls are infinitely stiff. Karnopp friction on the free mass keeps it from
// rattling between the walls.

#include "core/models/linearized_force.h"
#include "core/models/moving_average.h"
#include "core/models/virtual_mass.h"

namespace hapticlab {

class Backlash {
 public:
  // Centres the mass on the instrument.
  void reset(double x_hi, double v_hi) noexcept;
  // Keeps the mass within the (possibly new) gap of the instrument.
  void confine(double x_hi, double gap) noexcept;

  // Mass position limited to x_hi ± gap/2: the position the VE sees and the
  // input of the VE, cogging and friction models.
  double limited_position(double x_hi, double gap) const noexcept;
  // True when the mass is held at a gap wall (the instrument pushes it).
  bool at_wall(double x_hi, double gap) const noexcept;

  // `on_mass` are the VE, cogging and friction forces (linearized in the mass
  // position). Returns the force on the instrument [F].
  double step(const InertiaParams& inertia, const BacklashParams& p, double x_hi, double v_hi,
              const LinearizedForce& on_mass, double dt_s) noexcept;

  const VirtualMass& mass() const noexcept { return mass_; }

 private:
  VirtualMass mass_;
  ShortWindowAverage average_;
};

}  // namespace hapticlab
