#pragma once
// Status flags reported by every engine update. They are bits so that one
// update can report several conditions; the C API exposes the same values.

#include <cstdint>

namespace hapticlab {

enum StatusFlag : std::uint32_t {
  kStatusOk = 0,
  // An input (position, VE force or dt) was NaN or infinite. The displayed
  // force is zero for this update; the engine recovers once inputs are finite.
  kFaultNonFiniteInput = 1u << 0,
  // An intermediate value became non-finite: a finite input so large that
  // arithmetic overflowed, or a subnormal virtual mass (docs/engine.md,
  // Safety). The output was zeroed and the instrument state was reset.
  kFaultNonFiniteState = 1u << 1,
  // dt was below 1/2000 s (or <= 0): no time advanced in this update and the
  // velocity estimates were held; a positive dt is carried into the next update.
  kDtDeferred = 1u << 2,
  // dt was above 1/150 s: the update was split into sub-steps of at most 1/150 s.
  kDtSubstepped = 1u << 3,
  // dt was longer than the engine can bridge by sub-stepping (a stall): the
  // dynamic states were re-anchored to the instrument so no energy is injected.
  kDtResynced = 1u << 4,
  // The commanded force or torque hit the device limit on at least one axis.
  kForceLimited = 1u << 5,
  // The call itself was invalid (e.g. an instrument index other than 0 or 1);
  // nothing was computed and the force is zero.
  kFaultInvalidArgument = 1u << 6,
  // The caller's clock stopped: kMaxStalledUpdates updates in a row advanced
  // no time (dt <= 0, or below 1/2000 s all together). The models cannot
  // follow a hand that moves while no time passes (an inertia's coupling
  // spring would stretch to the device limit), so the force is zero until
  // time advances again; then the states are re-anchored (kDtResynced).
  kFaultClockStopped = 1u << 7,
};

// Flags that mean "the displayed force was forced to zero".
inline constexpr std::uint32_t kFaultMask =
    kFaultNonFiniteInput | kFaultNonFiniteState | kFaultInvalidArgument | kFaultClockStopped;

}  // namespace hapticlab
