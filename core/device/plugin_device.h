#pragma once
// PluginDevice, the "plugin:PATH" backend: a Device implemented by a shared
// library through the C ABI of core/capi/hapticlab/device_plugin.h.
//
// Loading refuses, with a message naming the file and the value: a missing
// file, a library that does not load or lacks hl_device_plugin_entry, a
// table of another ABI version or size, a required function left NULL, and
// options the plugin's create() rejects. configure() also fetches the
// ratings and refuses invalid ones (configure_error() says which).
//
// The boundary is guarded both ways: a reading with a non-finite position is
// kNonFiniteReading whatever the plugin said, and a command with a
// non-finite force is never passed on (zero force is sent instead and
// write() returns kWriteFailed), and a force beyond the rated peak_force is
// clipped to it before the plugin sees it. A status code the ABI does not define
// counts as the call's failure status, and status_detail() names the code
// and the call ("the plugin's read returned 42, which is no hl_device_status
// (taken as read_failed)") when it was the first failure since activate().
//
// A plugin with the simulation extension is also a HandAttachment, so the
// simulated participant holds it exactly as it holds the built-in sim.
//
// Threads as for Device. Not copyable or movable: the loop and the
// participant hold pointers to it, and the plugin's clock callback holds one
// to the loop's clock.

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <string>

#include "core/capi/hapticlab/device_plugin.h"
#include "core/device/device.h"
#include "core/device/hand_attachment.h"

namespace hapticlab {

class PluginDevice final : public Device, public HandAttachment {
 public:
  // Called with the name of each loading step before it runs ("load",
  // "create", ...), so a probe can say where a plugin crashed.
  using StageHook = void (*)(void* context, const char* stage);

  // Loads `path` and creates the device with `options`. Throws
  // std::runtime_error for a file that is not a usable plugin and
  // std::invalid_argument when the plugin rejects an option, both with a
  // message for the operator.
  PluginDevice(const std::string& path, const std::map<std::string, std::string>& options,
               StageHook stage = nullptr, void* stage_context = nullptr);
  ~PluginDevice() override;
  PluginDevice(const PluginDevice&) = delete;
  PluginDevice& operator=(const PluginDevice&) = delete;

  // --- Device
  DeviceStatus configure(const DeviceConfig& config) override;
  DeviceStatus activate(const Clock& clock) override;
  DeviceStatus read(DeviceReading& reading) noexcept override;
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() noexcept override;
  void halt() noexcept override;
  const char* name() const noexcept override;
  DeviceRatings ratings() const noexcept override { return ratings_; }
  HandAttachment* hand_attachment() noexcept override { return table_->sim != nullptr ? this : nullptr; }
  std::string status_detail() const override;

  // --- HandAttachment (only with the plugin's simulation extension)
  bool set_start_pose(int instrument, const DeviceJoints& position) noexcept override;
  void set_hand(int instrument, const HandCouplings& hand) noexcept override;
  DeviceJoints hand_force(int instrument) const noexcept override;
  DeviceJoints motor_force(int instrument) const noexcept override;

  // Why the last configure() failed, for the operator ("" after a success).
  const std::string& configure_error() const noexcept { return configure_error_; }
  // The first failure since the last activate(), when it was a status code
  // outside the ABI's: `op` is the call's number (kCheckedCalls in
  // plugin_device.cc); 0 when no call failed, -1 when the first failure
  // was a code of the ABI (nothing more to say of it).
  struct UnknownStatus {
    std::int32_t op = 0;
    std::int32_t code = 0;
  };
  UnknownStatus unknown_status() const noexcept {
    return {unknown_op_.load(std::memory_order_relaxed), unknown_code_.load(std::memory_order_relaxed)};
  }
  const std::string& path() const noexcept { return path_; }

 private:
  static constexpr std::size_t kNameChars = 63;
  void keep_name(const char* name) noexcept;
  // The plugin's answer to call `op` as a DeviceStatus; a code the ABI does
  // not define is the call's failure status, and is kept (with the call)
  // for status_detail() if it is the first failure since activate().
  DeviceStatus checked(hl_device_status status, std::int32_t op) noexcept;

  std::string path_;
  std::array<char, kNameChars + 1> name_{};
  void* library_ = nullptr;
  const hl_device_plugin* table_ = nullptr;
  hl_device* device_ = nullptr;
  hl_device_clock clock_{};
  DeviceRatings ratings_ = workstation_ratings();
  std::string configure_error_;
  bool active_ = false;
  // Written by the loop's thread, read by whoever reports the fault.
  std::atomic<std::int32_t> unknown_op_{0}, unknown_code_{0};
};

// Checks `path` without loading it: it exists, is a regular file and an
// ELF shared object (its first bytes). For a command that opens the device
// only later (the console): a file that is no plugin is refused at
// start-up ("no such file", "is a directory", "is not a shared library").
// Nothing of the plugin runs in this process (its static constructors
// would, unsupervised, if it were loaded here); whether it exports
// hl_device_plugin_entry is found when a session loads it, in the plugin
// host when isolated. Throws std::runtime_error.
void check_plugin_library(const std::string& path);

// "the plugin's read returned 42, which is no hl_device_status (taken as
// read_failed)": `op` as PluginDevice::UnknownStatus gives it; "" for op 0
// or one out of range.
std::string describe_unknown_status(PluginDevice::UnknownStatus unknown);

// The rules of DeviceRatings: every value finite, max_position >
// min_position, continuous_force >= 0, peak_force >= continuous_force,
// max_velocity > 0, and every value within what a hand-held device can
// be (kPlausibleRatings): a device's ratings set the loop's range and
// speed guard and the host's force clip, so a rating of 1e308 would
// switch them off. Returns "" if they hold, else a message naming
// `source`, the instrument, the joint, the field, its value and the bound.
std::string check_ratings(const std::string& source, const DeviceRatings& ratings);

// The bounds of a plausible rating, per kind of joint. Ten times or more
// beyond any laparoscopic or desktop haptic device (the workstation: 0.17 m
// of travel, 5.6 N peak; the largest desktop devices about 40 N and a few
// N·m, well under 1 m and 10 m/s), so that no real device is refused, and a
// value past them is a plugin's or driver's mistake, not a device.
struct PlausibleRatings {
  double translation_travel_m = 1.0;     // |min_position|, |max_position| of insertion
  double translation_force_N = 100.0;    // peak_force of insertion
  double translation_speed_m_per_s = 10.0;
  double rotation_travel_rad = 12.566370614359172;  // 4 pi: two turns each way (twist, grip, pitch, yaw)
  double rotation_torque_Nm = 20.0;
  double rotation_speed_rad_per_s = 100.0;
};
inline constexpr PlausibleRatings kPlausibleRatings{};

// Loads the plugin in a child process (a fork of this one) and runs create,
// configure (with `config`), ratings and destroy there; the parent only
// waits. Only in a process with one thread: with more it refuses (a fork
// inherits the locks other threads hold); probe_device() then uses the
// plugin host, a fresh process. Returns
// normally if all succeeded. Throws std::runtime_error with the loader's
// message for a plugin that is refused, and for one that crashes, exits or
// hangs (longer than timeout_s) in a step:
//   "plugin PATH crashed (SIGSEGV) in configure; nothing was started".
void probe_plugin(const std::string& path, const std::map<std::string, std::string>& options,
                  const DeviceConfig& config, double timeout_s = 10.0);

}  // namespace hapticlab
