#pragma once
// How much of the tissue's force a trial let the hand feel: the force
// information a simulated participant learns from (practice.h).
//
// Over the loop updates of a trial, both instruments:
//   I = (Σ f_shown·f_ve)² / (Σ|f_shown|² · Σ|f_ve|²)
// with f_ve the VE's force on the tool tip and f_shown the force the engine
// has the device display (its degradations included) [N]: the share of the
// tissue's force that the shown force explains, the uncentred R² of f_ve
// regressed on f_shown through the origin (a squared cosine, so within
// [0, 1] by Cauchy–Schwarz). It is 1 when the device shows the tissue's
// force up to a scale a hand adapts to, 0 with no force feedback, and falls
// with every force the device adds that the tissue did not make (friction,
// cogging, inertia in free motion) or bends (saturation). It is computed
// from forces only, never from a setting's name.
//
// A trial in which either sum of squares is 0 (no VE force, or nothing
// shown) carried no force to learn from: I = 0.

#include <Eigen/Core>

namespace hapticlab {

class ForceInformation {
 public:
  // Real-time safe: three sums, no allocation.
  void add(const Eigen::Vector3d& shown_N, const Eigen::Vector3d& ve_N) noexcept {
    shown_N2_ += shown_N.squaredNorm();
    ve_N2_ += ve_N.squaredNorm();
    cross_N2_ += shown_N.dot(ve_N);
  }
  // I in [0, 1] (see above).
  double value() const noexcept;

 private:
  double shown_N2_ = 0.0;
  double ve_N2_ = 0.0;
  double cross_N2_ = 0.0;
};

}  // namespace hapticlab
