#pragma once
// The degradation engine: two instruments (left = 0, right = 1) sharing one
// set of settings that can be swapped while the haptic loop runs.
//
// Threads: update() is called by one real-time thread (it is noexcept, does
// not allocate, lock or do I/O). set_settings() may be called from any other
// thread; the new settings take effect atomically at the start of the next
// update of each instrument, so both instruments switch between two
// consecutive updates and no update mixes old and new parameters.

#include <array>
#include <cstdint>
#include <optional>

#include "core/engine/instrument.h"
#include "core/engine/settings_exchange.h"
#include "core/settings/settings.h"

namespace hapticlab {

class Engine {
 public:
  // Throws SettingsError if `settings` break a documented range
  // (validate_settings); files loaded with settings_json.h already passed.
  explicit Engine(const EngineSettings& settings,
                  const std::array<JointVector, kNumInstruments>& start_positions = {
                      JointVector(0.1, 0.0, 0.0), JointVector(0.1, 0.0, 0.0)});

  // Real-time thread. instrument is 0 or 1 (other values return a zero force
  // with kFaultInvalidArgument set).
  InstrumentOutput update(int instrument, const InstrumentInput& in) noexcept;
  // Real-time thread, right after update(instrument, ...): the VE force for
  // this update's degraded positions replaces the one update() was given
  // (Instrument::refresh_forces). Ignored for an invalid instrument.
  void refresh_forces(int instrument, const Eigen::Vector3d& ve_force_N, InstrumentOutput& out) noexcept;

  // Control thread. Validates first (throws SettingsError, and nothing
  // changes, if a field is out of range), then publishes.
  void set_settings(const EngineSettings& settings);

  // Settings in use by the real-time side (read it from that thread).
  const EngineSettings& settings() const noexcept { return exchange_.current(); }

 private:
  TripleBuffer<EngineSettings> exchange_;
  std::array<Instrument, kNumInstruments> instruments_;
  // Shared: both instruments of one loop update see the same dt.
  ButterworthCache filters_;
  std::uint64_t generation_ = 0;
  std::array<std::uint64_t, kNumInstruments> applied_generation_{};
};

}  // namespace hapticlab
