#pragma once
// Opens the device a DeviceSpec names (device_spec.h): constructs it and
// checks its options. The caller configures and activates it.

#include <memory>

#include "core/device/device.h"
#include "core/device/device_spec.h"
#include "core/device/sim_device.h"

namespace hapticlab {

// Throws std::invalid_argument for an unknown option, std::runtime_error
// when the device cannot be opened (a plugin file missing or of another
// ABI version, ...), with a message for the operator.
std::unique_ptr<Device> open_device(const DeviceSpec& spec);

// What open_device refuses without touching the device: unknown or bad
// options, an --insecure that does not apply, for the UDP bridge an
// unreadable key file or a host beyond loopback without a key or
// --insecure, and for a plugin a file that is no plugin (loaded and its
// entry point looked up, check_plugin_library; no device is made, and the
// plugin's options are its create()'s to judge, at the first session).
// For a command that opens the device only later (the console). Throws
// std::invalid_argument as open_device does, a plugin's message after
// "--device plugin:PATH: ".
void check_device_spec(const DeviceSpec& spec);

// Before a session or a check: a device plugin is loaded, created and
// configured (with `config`) in a child process, so one that crashes is
// reported ("plugin PATH crashed (SIGSEGV) in configure; nothing was
// started") instead of taking the session down: in the plugin host
// (plugin_host_executable(), a fresh process) whenever one is registered,
// else (an isolated plugin is then refused) in a fork of this process,
// which probe_plugin refuses if the process has other threads. Other
// backends: nothing. Throws std::runtime_error with the message.
void probe_device(const DeviceSpec& spec, const DeviceConfig& config);

// The simulated workstation as the "sim" backend (and the sim plugin) runs it.
SimDeviceParams sim_backend_params();

}  // namespace hapticlab
