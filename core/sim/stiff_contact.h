#pragma once
// A stiff-contact stability run (issue 19 §1, thesis 2.3.4): the simulated
// device held by a hand that presses the tool into a stiff VE, one
// instrument, the engine between them, at a fixed update rate on a virtual
// clock. It answers whether a setting stays stable there, by the two
// criteria issue 19 names: the energy the device gives the hand, and the
// oscillation of the tool tip once the contact has settled.
//
// Each update, as the haptic loop runs it: read the device (its physics
// advanced by dt), engine step with the previous VE force, the VE's force
// for the new degraded tip, engine refresh_forces, write. The VE is either
//   - a wall: a plane through the tip's start, normal to the tool, pushing
//     back with k·depth while the tip is beyond it (unilateral); or
//   - grasped tissue: the tip tied to its start by a 3-D spring k (the
//     thesis' "tool tip between two walls", both instruments holding
//     tissue), which also loads pitch and yaw.
// The hand (a spring–damper with the arm's mass, as SimDevice couples it)
// pushes its reference `press_N`/k_hand beyond the start along the tool;
// pitch and yaw it holds at the start with the same tip stiffness through
// the lever (K·L²).
//
// Deterministic: the same config gives the same result, bit for bit.
#include <cstdint>

#include "core/settings/settings.h"

namespace hapticlab {

enum class StiffContactKind : std::uint8_t { kWall, kGraspedTissue };

struct StiffContactConfig {
  EngineSettings settings;
  double rate_Hz = 1000.0;                 // 150..2000
  StiffContactKind kind = StiffContactKind::kWall;
  double stiffness_N_per_m = 2000.0;       // VE, > 0
  double damping_N_s_per_m = 0.0;          // VE, >= 0
  double press_N = 3.0;                    // what the hand means to push with, >= 0
  // The arm (core/sim/hand.h HandParams defaults: 600 N/m, ζ 0.8, 0.3 kg).
  double hand_stiffness_N_per_m = 600.0;
  double hand_damping_ratio = 0.8;
  double hand_mass_kg = 0.3;
  double duration_s = 3.0;                 // >= 1.5: the last second is judged
  double start_insertion_m = 0.085;        // mid-stroke
};

struct StiffContactResult {
  // Peak-to-peak of the device's tool tip over the last second, the largest
  // of the three world axes [m].
  double oscillation_m = 0.0;
  // Net energy the device gave the hand over the run [J] (Σ F_k·Δq, the
  // zero-order hold of device_energy.h): > 0 is energy the loop generated.
  double device_net_J = 0.0;
  double peak_ve_force_N = 0.0;
  // The engine or the device faulted (a non-finite value, a joint beyond its
  // range): the run stopped there, counted unstable.
  bool faulted = false;
  double ran_s = 0.0;
};

// Throws std::invalid_argument naming a field out of its range.
StiffContactResult run_stiff_contact(const StiffContactConfig& config);

}  // namespace hapticlab
