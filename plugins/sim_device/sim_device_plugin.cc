// hapticlab_sim_device.so: the simulated workstation (SimDevice, with the
// parameters of the built-in `sim` backend) as a device plugin. A session
// with `--device plugin:hapticlab_sim_device.so` logs the same samples as
// one with `--device sim` (tests/app/device_plugin_session_test.cc), which
// proves the plugin path adds nothing to what the loop sees. It is also a
// working reference for the simulation extension.
//
// Options: max_substep_s=S, the longest physics sub-step [s], (0, 1e-3];
// default that of the built-in sim.
//
// No exception leaves this file: the ABI is C.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "core/capi/hapticlab/device_plugin.h"
#include "core/device/device_factory.h"
#include "core/device/sim_device.h"
#include "core/common/clock.h"

namespace {

using hapticlab::DeviceStatus;

// The loop's clock, seen through the ABI's callback.
class CallbackClock final : public hapticlab::Clock {
 public:
  void set(const hl_device_clock& clock) noexcept { clock_ = clock; }
  double now_s() const noexcept override { return clock_.now_s(clock_.context); }
  // SimDevice only reads the clock; the loop does the waiting.
  void sleep_until(double) noexcept override {}
  bool is_virtual() const noexcept override { return false; }

 private:
  hl_device_clock clock_{};
};

}  // namespace

struct hl_device {
  explicit hl_device(const hapticlab::SimDeviceParams& params) : sim(params) {}
  hapticlab::SimDevice sim;
  CallbackClock clock;
};

namespace {

void put_error(char* error, size_t size, const std::string& text) {
  if (error != nullptr && size > 0) std::snprintf(error, size, "%s", text.c_str());
}

hl_device* create(const char* const* keys, const char* const* values, size_t count, char* error,
                  size_t error_size) {
  try {
    hapticlab::SimDeviceParams params = hapticlab::sim_backend_params();
    for (size_t i = 0; i < count; ++i) {
      const std::string key = keys[i];
      if (key != "max_substep_s") {
        put_error(error, error_size, "'" + key + "' is not an option of the simulated workstation; it takes "
                                     "max_substep_s");
        return nullptr;
      }
      char* end = nullptr;
      const double value = std::strtod(values[i], &end);
      if (end == values[i] || *end != '\0' || !std::isfinite(value)) {
        put_error(error, error_size, "max_substep_s: '" + std::string(values[i]) + "' is not a number of seconds");
        return nullptr;
      }
      params.max_substep_s = value;
    }
    return new hl_device(params);  // SimDevice checks the ranges
  } catch (const std::exception& e) {
    put_error(error, error_size, e.what());
    return nullptr;
  }
}

hl_device_status configure(hl_device* d, double nominal_rate_Hz, uint64_t seed) {
  try {
    return static_cast<hl_device_status>(d->sim.configure({nominal_rate_Hz, seed}));
  } catch (...) {
    return HL_DEVICE_INVALID_CONFIG;
  }
}

hl_device_status ratings(const hl_device* d, hl_device_ratings* out) {
  const hapticlab::DeviceRatings r = d->sim.ratings();
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < HL_DEVICE_NUM_JOINTS; ++j) {
      const hapticlab::DeviceJointRating& x = r.joint[static_cast<size_t>(i)][static_cast<size_t>(j)];
      out->joint[i][j] = {x.min_position, x.max_position, x.continuous_force, x.peak_force, x.max_velocity};
    }
  return HL_DEVICE_OK;
}

hl_device_status activate(hl_device* d, const hl_device_clock* clock) {
  if (clock == nullptr || clock->now_s == nullptr) return HL_DEVICE_INVALID_CONFIG;
  d->clock.set(*clock);
  try {
    return static_cast<hl_device_status>(d->sim.activate(d->clock));
  } catch (...) {
    return HL_DEVICE_INVALID_CONFIG;
  }
}

hl_device_status read(hl_device* d, hl_device_reading* out) {
  hapticlab::DeviceReading r;
  const DeviceStatus status = d->sim.read(r);
  if (status == DeviceStatus::kReadFailed) return static_cast<hl_device_status>(status);
  std::memcpy(out->position, r.position.data(), sizeof out->position);
  out->device_time_s = r.device_time_s;
  return static_cast<hl_device_status>(status);
}

hl_device_status write(hl_device* d, const hl_device_command* command) {
  hapticlab::DeviceCommand c;
  std::memcpy(c.force.data(), command->force, sizeof command->force);
  return static_cast<hl_device_status>(d->sim.write(c));
}

hl_device_status deactivate(hl_device* d) { return static_cast<hl_device_status>(d->sim.deactivate()); }
void halt(hl_device* d) { d->sim.halt(); }
const char* name(const hl_device*) { return "sim-plugin"; }
void destroy(hl_device* d) { delete d; }

hapticlab::DeviceJoints joints(const double* x) {
  hapticlab::DeviceJoints j;
  std::memcpy(j.data(), x, sizeof(double) * HL_DEVICE_NUM_JOINTS);
  return j;
}

int set_start_pose(hl_device* d, int instrument, const double* position) {
  return d->sim.set_start_pose(instrument, joints(position)) ? 1 : 0;
}

void set_hand(hl_device* d, int instrument, const hl_hand_coupling* hand) {
  hapticlab::HandCouplings h;
  for (int j = 0; j < HL_DEVICE_NUM_JOINTS; ++j)
    h[static_cast<size_t>(j)] = {hand[j].reference_position, hand[j].reference_velocity, hand[j].stiffness,
                                 hand[j].damping, hand[j].force, hand[j].mass};
  d->sim.set_hand(instrument, h);
}

void hand_force(const hl_device* d, int instrument, double* force) {
  const hapticlab::DeviceJoints f = d->sim.hand_force(instrument);
  std::memcpy(force, f.data(), sizeof(double) * HL_DEVICE_NUM_JOINTS);
}

void motor_force(const hl_device* d, int instrument, double* force) {
  const hapticlab::DeviceJoints f = d->sim.motor_force(instrument);
  std::memcpy(force, f.data(), sizeof(double) * HL_DEVICE_NUM_JOINTS);
}

constexpr hl_device_sim_extension kSim = {&set_start_pose, &set_hand, &hand_force, &motor_force};

constexpr hl_device_plugin kPlugin = {
    HL_DEVICE_PLUGIN_ABI_VERSION, sizeof(hl_device_plugin), &create, &configure, &ratings, &activate, &read, &write,
    &deactivate, &halt, &name, &destroy, &kSim};

static_assert(sizeof(hapticlab::DeviceReading::position) == sizeof(hl_device_reading::position));
static_assert(sizeof(hapticlab::DeviceCommand::force) == sizeof(hl_device_command::force));

}  // namespace

extern "C" const hl_device_plugin* hl_device_plugin_entry(void) { return &kPlugin; }
