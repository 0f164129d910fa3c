#pragma once
// Which device a session drives, as the operator names it on the command
// line (`--device SPEC [--device-option key=value ...]`):
//
//   sim                  the simulated workstation, built in
//   plugin:PATH          a device plugin (a shared library implementing
//                        hapticlab/device_plugin.h), loaded with dlopen
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
  std::string host;        // kUdp
  int port = 0;            // kUdp, 1..65535
  std::map<std::string, std::string> options;
  // kUdp only: no key_file is acceptable for a host outside 127.0.0.0/8
  // (the operator said --insecure).
  bool insecure = false;

  // The spec as the operator wrote it, without options ("udp:127.0.0.1:5000").
  std::string describe() const;
};

// Throws std::invalid_argument naming the text and what is allowed.
DeviceSpec parse_device_spec(std::string_view text);
// Adds "key=value" options; throws std::invalid_argument for a malformed
// one or a key given twice.
void add_device_options(DeviceSpec& spec, const std::vector<std::string>& key_values);

}  // namespace hapticlab
