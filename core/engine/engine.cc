#include "core/engine/engine.h"

#include "core/engine/status.h"
#include "core/settings/settings_json.h"

namespace hapticlab {

namespace {
const EngineSettings& validated(const EngineSettings& s) {
  validate_settings(s);
  return s;
}
}  // namespace

Engine::Engine(const EngineSettings& settings,
               const std::array<JointVector, kNumInstruments>& start)
    : exchange_(validated(settings)),
      instruments_{Instrument(settings, start[0]), Instrument(settings, start[1])} {}

void Engine::set_settings(const EngineSettings& settings) {
  validate_settings(settings);
  exchange_.publish(settings);
}

InstrumentOutput Engine::update(int instrument, const InstrumentInput& in) noexcept {
  if (instrument < 0 || instrument >= kNumInstruments) {
    InstrumentOutput out;
    out.status = kFaultInvalidArgument;
    return out;
  }
  if (exchange_.take()) ++generation_;
  if (applied_generation_[instrument] != generation_) {
    instruments_[instrument].apply_settings(exchange_.current());
    applied_generation_[instrument] = generation_;
  }
  return instruments_[instrument].step(in, filters_);
}

void Engine::refresh_forces(int instrument, const Eigen::Vector3d& ve_force_N, InstrumentOutput& out) noexcept {
  if (instrument < 0 || instrument >= kNumInstruments) return;
  instruments_[instrument].refresh_forces(ve_force_N, out);
}

}  // namespace hapticlab
