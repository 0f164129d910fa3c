#pragma once
// The energy the device exchanged with the hand over one trial, per joint
// axis (insertion, pitch, yaw), and the engine's part of it: the per-trial
// measure that shows whether a degradation generated energy (went unstable)
// or only dissipated it (docs/analysis.md, "Energy").
//
// The command of update k is held until the next read (zero-order hold), so
// the work the device does on the hand in that interval is, on axis j,
//     W_k = F_k · (q_{k+1} − q_k)          [J]  (N·m or N·m·rad)
// with F_k the commanded joint force and q the joints as read from the
// device. W > 0: the device pushed along the motion (energy given to the
// hand); W < 0: the hand pushed the device (energy taken from it).
//
// The engine's part subtracts what the VE's own force would have done,
//     W^engine_k = (F_k − J(q_k)ᵀ F^ve_k) · (q_{k+1} − q_k)
// (J(q)ᵀ: the world-to-joint map of eq. 2.16–2.18, at the measured joints,
// as the engine applies it). So friction, damping and the device limit
// take energy; an unstable inertia or backlash model, or latency, gives it;
// a VE spring's store-and-return is the VE's, not the engine's. A passive
// engine has Σ W^engine <= 0 over a trial, up to the energy its models hold
// at the end (a stretched coupling spring).
//
// The intervals before and after an update whose values are not all finite
// (a device fault: the engine commands zero force then) add nothing; they
// are counted.
#include <array>
#include <cstddef>

#include "core/models/sin_cos.h"

namespace hapticlab::analysis {

struct AxisEnergy {
  double out_J = 0.0;  // Σ max(W, 0): given to the hand
  double in_J = 0.0;   // Σ max(−W, 0): taken from the hand
  double net_J() const { return out_J - in_J; }
};

struct HandEnergy {
  std::array<AxisEnergy, 3> device{};  // the whole commanded force (VE + engine)
  std::array<AxisEnergy, 3> engine{};  // the engine's part
  std::size_t intervals = 0;           // update-to-update intervals summed
  std::size_t skipped = 0;             // intervals left out (a value not finite)
  // Sums over the three axes.
  double device_out_J() const;
  double device_in_J() const;
  double device_net_J() const { return device_out_J() - device_in_J(); }
  double engine_out_J() const;
  double engine_in_J() const;
  double engine_net_J() const { return engine_out_J() - engine_in_J(); }
};

// Fed one hand's updates in time order.
class EnergyAccumulator {
 public:
  void start();
  // raw_position: the device's joints (insertion m, pitch rad, yaw rad,
  // twist, grip; the first three are used); joint_force: the commanded
  // insertion N, pitch and yaw N·m; ve_force_N: the VE's force on the tip,
  // world frame.
  void add(const std::array<double, 5>& raw_position, const std::array<double, 3>& joint_force,
           const std::array<double, 3>& ve_force_N);
  const HandEnergy& result() const { return energy_; }

 private:
  HandEnergy energy_;
  bool have_any_ = false;         // an update came before this one
  bool previous_finite_ = false;  // and all its values were finite
  std::array<double, 3> q_{};         // previous joints
  std::array<double, 3> f_{};         // previous command
  std::array<double, 3> f_ve_{};      // previous VE force in joint space
  // The pose's sines and cosines: a hand held still in contact reads the
  // same float32 angles update after update (the same bits as sincos()).
  LibmSinCosMemo pitch_, yaw_;
};

}  // namespace hapticlab::analysis
