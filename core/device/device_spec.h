#pragma once
// Which device a session drives, as the operator names it on the command
// line (`--device SPEC [--device-option key=value ...]`):
//
//   sim                  the simulated workstation, built in
//   plugin:PATH          a device plugin (a shared library implementing
//                        hapticlab/device_plugin.h): isolated when the loop
//                        runs real-time, in-process otherwise (below)
//   plugin-inprocess:PATH the plugin loaded with dlopen into this process
//                        (plugin_device.h)
//   plugin-isolated:PATH the same plugin run in a child process that
//                        HapticLab supervises (isolated_plugin_device.h):
//                        a crash or hang of the plugin ends the trial with
//                        its reason instead of the session; costs a round
//                        trip per call (docs/devices.md, "Isolated plugins")
//   udp:HOST:PORT        a device driver in another process or on another
//   udp:PORT             PC, through the UDP bridge (docs/udp_bridge.md);
//                        HOST defaults to 127.0.0.1
//
// Options are free-form key=value pairs passed to the backend (a plugin's
// configure(), the bridge's timeout and key file); each backend rejects
// keys it does not know, naming them. `--insecure` lets the bridge run
// without a key to a host beyond loopback.

#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace hapticlab {

class Device;

struct DeviceSpec {
  enum class Kind : std::uint8_t { kSim, kPlugin, kUdp };
  Kind kind = Kind::kSim;
  std::string path;        // kPlugin: the shared library
  // kPlugin: how the operator asked for it to run ("plugin:" = kDefault).
  enum class PluginMode : std::uint8_t { kDefault, kInProcess, kIsolated };
  PluginMode plugin_mode = PluginMode::kDefault;
  std::string host;        // kUdp
  int port = 0;            // kUdp, 1..65535
  std::map<std::string, std::string> options;
  // kUdp only: no key_file is acceptable for a host outside 127.0.0.0/8
  // (the operator said --insecure).
  bool insecure = false;
  // The haptic loop runs SCHED_FIFO (--realtime, granted): what "plugin:"
  // means depends on it (kIsolationCostsLittleUnderRealtime).
  bool realtime_loop = false;

  // The spec as the operator wrote it, without options ("udp:127.0.0.1:5000",
  // "plugin-isolated:/opt/lab/acme.so").
  std::string describe() const;
  // kPlugin: whether it runs in a child process (kDefault: when the loop
  // runs real-time).
  bool isolated() const noexcept;
};

// What "plugin:PATH" means: isolation is the default where it costs less
// than 20 µs at p99 per update, which is when the loop (and with it the
// plugin's host process) runs SCHED_FIFO: measured 0.3-4.7 µs there, and
// 150-1200 µs under normal scheduling on the project's shared 2-core
// machine, where the host process is not on a CPU when the loop calls
// (BENCHMARKS.md, "Isolated device plugins"; docs/devices.md).
inline constexpr bool kIsolationCostsLittleUnderRealtime = true;

// Throws std::invalid_argument naming the text and what is allowed.
DeviceSpec parse_device_spec(std::string_view text);
// Adds "key=value" options; throws std::invalid_argument for a malformed
// one or a key given twice.
void add_device_options(DeviceSpec& spec, const std::vector<std::string>& key_values);

}  // namespace hapticlab
