// The C API: a thin shell over hapticlab::Engine. No exception crosses it.
#include "hapticlab/hapticlab.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <new>
#include <string>

#include "core/engine/engine.h"
#include "core/engine/joint_transform.h"
#include "core/engine/status.h"
#include "core/settings/settings_json.h"

struct hl_engine {
  explicit hl_engine(const hapticlab::EngineSettings& s) : engine(s) {}
  hapticlab::Engine engine;
  // Each instrument's last update() result: refresh_forces needs its pose and
  // status, which hl_output does not carry in the engine's form.
  std::array<hapticlab::InstrumentOutput, hapticlab::kNumInstruments> last{};
  // Set by a successful update, cleared by a failed one and by the refresh:
  // a refresh must never revive the forces of an earlier update.
  std::array<bool, hapticlab::kNumInstruments> refreshable{};
  // Operator stop (hl_engine_halt), set from any thread, read once per
  // update and refresh on the loop thread.
  std::atomic<bool> halted{false};
  // hl_engine_set_ramp_in: ramp length [s] (0: off), each instrument's time
  // since it was set [s], and the ramp's time of the current update: the
  // time before that update's dt, so the first update commands exactly
  // zero, as the loop's ForceGuard does (its t_s is 0 at the first update).
  double ramp_in_s = 0.0;
  // hl_engine_fix_settings: no other settings, no shorter ramp-in.
  bool settings_fixed = false;
  double min_ramp_in_s = 0.0;
  std::array<double, hapticlab::kNumInstruments> ramp_elapsed_s{};
  std::array<double, hapticlab::kNumInstruments> ramp_t_s{};
};

namespace {

static_assert(HL_FAULT_NON_FINITE_INPUT == hapticlab::kFaultNonFiniteInput);
static_assert(HL_FAULT_NON_FINITE_STATE == hapticlab::kFaultNonFiniteState);
static_assert(HL_DT_DEFERRED == hapticlab::kDtDeferred);
static_assert(HL_DT_SUBSTEPPED == hapticlab::kDtSubstepped);
static_assert(HL_DT_RESYNCED == hapticlab::kDtResynced);
static_assert(HL_FORCE_LIMITED == hapticlab::kForceLimited);
static_assert(HL_FAULT_INVALID_ARGUMENT == hapticlab::kFaultInvalidArgument);
static_assert(HL_FAULT_CLOCK_STOPPED == hapticlab::kFaultClockStopped);
static_assert(HL_CLOCK_STOPPED_UPDATES == hapticlab::kMaxStalledUpdates);
static_assert(HL_FAULT_MASK == hapticlab::kFaultMask);

void write_error(char* error, size_t size, const std::string& message) {
  if (error != nullptr && size > 0) std::snprintf(error, size, "%s", message.c_str());
}

template <typename Load>
hl_engine* create(Load load, char* error, size_t error_size) {
  try {
    const hapticlab::NamedSettings s = load();
    write_error(error, error_size, "");
    return new hl_engine(s.engine);
  } catch (const std::exception& e) {
    write_error(error, error_size, e.what());
  } catch (...) {
    write_error(error, error_size, "unknown error");
  }
  return nullptr;
}

void copy_forces(const hapticlab::InstrumentOutput& r, hl_output* out) {
  for (int i = 0; i < 3; ++i) out->displayed_force_N[i] = r.displayed_force_N[i];
  out->insertion_force_N = r.joint_force[hapticlab::kInsertion];
  out->pitch_torque_Nm = r.joint_force[hapticlab::kPitch];
  out->yaw_torque_Nm = r.joint_force[hapticlab::kYaw];
  out->status = r.status;
}

static_assert((HL_RAMPING & (HL_HALTED | HL_FAULT_MASK | hapticlab::kFaultMask | HL_DT_DEFERRED | HL_DT_SUBSTEPPED |
                              HL_DT_RESYNCED | HL_FORCE_LIMITED)) == 0,
              "HL_RAMPING must not share a bit with the other status flags");
static_assert((HL_HALTED & (HL_FAULT_MASK | hapticlab::kFaultMask | HL_DT_DEFERRED | HL_DT_SUBSTEPPED |
                             HL_DT_RESYNCED | HL_FORCE_LIMITED)) == 0,
              "HL_HALTED must not share a bit with the engine's status flags");

// Scales the output's forces by the instrument's ramp-in (1 once it is over).
void apply_ramp_in(const hl_engine& engine, int instrument, hl_output* out) {
  if (!(engine.ramp_in_s > 0.0)) return;
  const double scale = engine.ramp_t_s[static_cast<std::size_t>(instrument)] / engine.ramp_in_s;
  if (scale >= 1.0) return;
  const double s = std::max(0.0, scale);
  for (double& f : out->displayed_force_N) f *= s;
  out->insertion_force_N *= s;
  out->pitch_torque_Nm *= s;
  out->yaw_torque_Nm *= s;
  out->status |= HL_RAMPING;
}

// A halted engine's output: positions as computed, every force zero.
void zero_forces_if_halted(const hl_engine& engine, hl_output* out) {
  if (!engine.halted.load(std::memory_order_relaxed)) return;
  for (double& f : out->displayed_force_N) f = 0.0;
  out->insertion_force_N = out->pitch_torque_Nm = out->yaw_torque_Nm = 0.0;
  out->status |= HL_HALTED;
}

bool valid_instrument(int instrument) {
  return instrument >= 0 && instrument < hapticlab::kNumInstruments;
}

}  // namespace

extern "C" {

const char* hl_version(void) { return HAPTICLAB_VERSION_STRING; }

hl_engine* hl_engine_create(const char* settings_json, char* error, size_t error_size) {
  if (settings_json == nullptr) {
    write_error(error, error_size, "hl_engine_create: settings_json is NULL");
    return nullptr;
  }
  return create([&] { return hapticlab::settings_from_json_text(settings_json, "settings"); },
                error, error_size);
}

hl_engine* hl_engine_create_from_file(const char* path, char* error, size_t error_size) {
  if (path == nullptr) {
    write_error(error, error_size, "hl_engine_create_from_file: path is NULL");
    return nullptr;
  }
  return create([&] { return hapticlab::load_settings_file(path); }, error, error_size);
}

int hl_engine_update(hl_engine* engine, int instrument, const hl_input* in, hl_output* out) {
  if (engine != nullptr && valid_instrument(instrument))
    engine->refreshable[static_cast<std::size_t>(instrument)] = false;
  if (out == nullptr) return HL_ERROR_INVALID_ARGUMENT;
  *out = hl_output{};
  out->orientation_offset[0] = out->orientation_offset[4] = out->orientation_offset[8] = 1.0;
  if (engine == nullptr || in == nullptr || !valid_instrument(instrument)) {
    out->status = HL_FAULT_INVALID_ARGUMENT;
    return HL_ERROR_INVALID_ARGUMENT;
  }
  hapticlab::InstrumentInput input;
  input.dt_s = in->dt_s;
  input.position = {in->insertion_m, in->pitch_rad, in->yaw_rad};
  input.ve_force_N = {in->ve_force_N[0], in->ve_force_N[1], in->ve_force_N[2]};
  hapticlab::InstrumentOutput& r = engine->last[static_cast<std::size_t>(instrument)];
  r = engine->engine.update(instrument, input);
  engine->refreshable[static_cast<std::size_t>(instrument)] = true;
  copy_forces(r, out);
  for (int i = 0; i < 3; ++i) {
    out->tip_offset_m[i] = r.tip_offset_m[i];
    for (int j = 0; j < 3; ++j) out->orientation_offset[3 * i + j] = r.orientation_offset(i, j);
  }
  out->degraded_insertion_m = r.degraded_position[hapticlab::kInsertion];
  out->degraded_pitch_rad = r.degraded_position[hapticlab::kPitch];
  out->degraded_yaw_rad = r.degraded_position[hapticlab::kYaw];
  const auto ui = static_cast<std::size_t>(instrument);
  engine->ramp_t_s[ui] = engine->ramp_elapsed_s[ui];
  if (std::isfinite(in->dt_s) && in->dt_s > 0.0) engine->ramp_elapsed_s[ui] += in->dt_s;
  apply_ramp_in(*engine, instrument, out);
  zero_forces_if_halted(*engine, out);
  return HL_OK;
}

int hl_engine_refresh_forces(hl_engine* engine, int instrument, const double ve_force_N[3],
                             hl_output* out) {
  if (engine == nullptr || ve_force_N == nullptr || out == nullptr || !valid_instrument(instrument)) {
    return HL_ERROR_INVALID_ARGUMENT;
  }
  const auto i = static_cast<std::size_t>(instrument);
  if (!engine->refreshable[i]) return HL_OK;  // nothing to refresh: out stays as it is
  engine->refreshable[i] = false;
  hapticlab::InstrumentOutput& r = engine->last[i];
  // The engine itself declines (and leaves r as update() made it) when the
  // update faulted or loop emulation owns the VE force's timing; copying r
  // back then writes the update's own forces.
  engine->engine.refresh_forces(instrument, {ve_force_N[0], ve_force_N[1], ve_force_N[2]}, r);
  copy_forces(r, out);
  apply_ramp_in(*engine, instrument, out);
  zero_forces_if_halted(*engine, out);
  return HL_OK;
}

int hl_engine_set_ramp_in(hl_engine* engine, double ramp_s) {
  if (engine == nullptr || !(ramp_s >= 0.0 && ramp_s <= 10.0)) return HL_ERROR_INVALID_ARGUMENT;
  if (ramp_s < engine->min_ramp_in_s) return HL_ERROR_INVALID_ARGUMENT;
  engine->ramp_in_s = ramp_s;
  engine->ramp_elapsed_s = {};
  engine->ramp_t_s = {};
  return HL_OK;
}

int hl_engine_set_settings(hl_engine* engine, const char* settings_json, char* error,
                           size_t error_size) {
  if (engine == nullptr || settings_json == nullptr) {
    write_error(error, error_size, "hl_engine_set_settings: engine or settings_json is NULL");
    return HL_ERROR_INVALID_ARGUMENT;
  }
  if (engine->settings_fixed) {
    // A study's trial: what its participant feels is the setting the study
    // stores for the trial, nothing else.
    write_error(error, error_size,
                "hl_engine_set_settings: this engine's settings are fixed (hl_engine_fix_settings: the study API "
                "fixes each trial's engine to the trial's setting); nothing changed");
    return HL_ERROR_SETTINGS;
  }
  try {
    engine->engine.set_settings(
        hapticlab::settings_from_json_text(settings_json, "settings").engine);
    write_error(error, error_size, "");
    return HL_OK;
  } catch (const std::exception& e) {
    write_error(error, error_size, e.what());
  } catch (...) {
    write_error(error, error_size, "unknown error");
  }
  return HL_ERROR_SETTINGS;
}

void hl_engine_fix_settings(hl_engine* engine) {
  if (engine == nullptr) return;
  engine->settings_fixed = true;
  engine->min_ramp_in_s = engine->ramp_in_s;
}

void hl_engine_halt(hl_engine* engine) {
  if (engine != nullptr) engine->halted.store(true, std::memory_order_relaxed);
}

void hl_engine_destroy(hl_engine* engine) { delete engine; }

int hl_tip_position(double insertion_m, double pitch_rad, double yaw_rad, double tip_m[3]) {
  if (tip_m == nullptr) return HL_ERROR_INVALID_ARGUMENT;
  const Eigen::Vector3d tip = hapticlab::tip_position(hapticlab::JointVector(insertion_m, pitch_rad, yaw_rad));
  for (int i = 0; i < 3; ++i) tip_m[i] = tip[i];
  return HL_OK;
}

}  // extern "C"
