#include "core/device/device_factory.h"

#include <stdexcept>

#include "core/device/isolated_plugin_device.h"
#include "core/device/plugin_device.h"
#include "core/device/sim_device.h"
#include "core/device/udp_device.h"

namespace hapticlab {
namespace {

void reject_options(const DeviceSpec& spec) {
  if (!spec.options.empty())
    throw std::invalid_argument("device-option: '" + spec.options.begin()->first + "' is not an option of the " +
                                spec.describe() + " device, which takes none");
}

UdpDeviceOptions udp_options(const DeviceSpec& spec) {
  UdpDeviceOptions options;
  options.host = spec.host;
  options.port = spec.port;
  options.insecure = spec.insecure;
  for (const auto& [key, value] : spec.options) {
    if (key == "key_file") {
      if (value.empty()) throw std::invalid_argument("device-option key_file: names no file");
      options.key_file = value;
      continue;
    }
    if (key != "timeout_ms")
      throw std::invalid_argument("device-option: '" + key + "' is not an option of the " + spec.describe() +
                                  " device; it takes timeout_ms (1..1000, default 10) and key_file (the shared "
                                  "key, docs/udp_bridge.md)");
    std::size_t end = 0;
    int ms = 0;
    try {
      ms = std::stoi(value, &end);
    } catch (const std::exception&) {
      end = 0;
    }
    if (end == 0 || end != value.size() || ms < 1 || ms > 1000)
      throw std::invalid_argument("device-option timeout_ms: '" + value +
                                  "' is not a whole number of milliseconds in 1..1000");
    options.timeout_ms = ms;
  }
  return options;
}

void check_insecure(const DeviceSpec& spec) {
  if (spec.insecure && spec.kind != DeviceSpec::Kind::kUdp)
    throw std::invalid_argument("--insecure: applies to the UDP bridge (udp:HOST:PORT) only, not to the " +
                                spec.describe() + " device");
}

}  // namespace

std::unique_ptr<Device> open_device(const DeviceSpec& spec) {
  check_insecure(spec);
  switch (spec.kind) {
    case DeviceSpec::Kind::kSim: {
      reject_options(spec);
      return std::make_unique<SimDevice>(sim_backend_params());
    }
    case DeviceSpec::Kind::kPlugin:
      if (!spec.isolated()) return std::make_unique<PluginDevice>(spec.path, spec.options);
      return std::make_unique<IsolatedPluginDevice>(plugin_host_executable(), spec.path, spec.options);
    case DeviceSpec::Kind::kUdp: return std::make_unique<UdpDevice>(udp_options(spec));
  }
  throw std::runtime_error("device: " + spec.describe() + " cannot be opened by this build");
}

void check_device_spec(const DeviceSpec& spec) {
  check_insecure(spec);
  if (spec.kind == DeviceSpec::Kind::kSim) reject_options(spec);
  if (spec.kind == DeviceSpec::Kind::kUdp) (void)UdpDevice::checked_key(udp_options(spec));
  if (spec.kind == DeviceSpec::Kind::kPlugin) {
    try {
      check_plugin_library(spec.path);
    } catch (const std::runtime_error& e) {
      throw std::invalid_argument("--device " + spec.describe() + ": " + e.what());
    }
  }
}

SimDeviceParams sim_backend_params() {
  // Sub-steps of 1 ms are plenty for a hand of a few hundred N/m on a few
  // hundred grams (ω·h < 0.05) and keep a 1 kHz loop at one physics step
  // per update.
  SimDeviceParams params;
  params.max_substep_s = 1e-3;
  return params;
}

namespace {

// The probe in the plugin host: a fresh process (posix_spawn, exec), not a
// fork of this one, whose other threads (the console's, say) may hold a
// lock the child would inherit; says what the fork's probe says.
void probe_in_host(const DeviceSpec& spec, const DeviceConfig& config) {
  const std::string nothing_started = "; nothing was started";
  try {
    IsolatedPluginDevice device(plugin_host_executable(), spec.path, spec.options);
    if (device.configure(config) == DeviceStatus::kOk) return;
    const std::string end = device.process_end();
    throw std::runtime_error(end.empty() ? device.configure_error()
                                         : "plugin " + spec.path + " " + end + nothing_started);
  } catch (const PluginProcessError& e) {
    throw std::runtime_error(e.what() + nothing_started);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
}

}  // namespace

void probe_device(const DeviceSpec& spec, const DeviceConfig& config) {
  if (spec.kind != DeviceSpec::Kind::kPlugin) return;
  // An in-process plugin is probed in the host too whenever there is one
  // (the hapticlab command): the forked probe is safe only in a process
  // with one thread, and refuses otherwise.
  if (spec.isolated() || !plugin_host_executable().empty()) probe_in_host(spec, config);
  else probe_plugin(spec.path, spec.options, config);
}

}  // namespace hapticlab
