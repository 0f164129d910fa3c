#include "core/device/device_spec.h"

#include <charconv>
#include <stdexcept>
#include <utility>

namespace hapticlab {
namespace {

constexpr const char* kAllowed =
    "allowed: sim, plugin:PATH.so, plugin-isolated:PATH.so, plugin-inprocess:PATH.so, udp:PORT or udp:HOST:PORT";

[[noreturn]] void fail(std::string_view text, const std::string& why) {
  throw std::invalid_argument("device: '" + std::string(text) + "' " + why + " (" + kAllowed + ")");
}

int parse_port(std::string_view whole, std::string_view port) {
  int value = 0;
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
  if (ec != std::errc() || end != port.data() + port.size() || value < 1 || value > 65535)
    fail(whole, "has port '" + std::string(port) + "', which is not a number in 1..65535");
  return value;
}

}  // namespace

std::string DeviceSpec::describe() const {
  switch (kind) {
    case Kind::kSim: return "sim";
    case Kind::kPlugin:
      switch (plugin_mode) {
        case PluginMode::kDefault: return "plugin:" + path;
        case PluginMode::kInProcess: return "plugin-inprocess:" + path;
        case PluginMode::kIsolated: return "plugin-isolated:" + path;
      }
      break;
    case Kind::kUdp: return "udp:" + host + ":" + std::to_string(port);
  }
  return "unknown";
}

bool DeviceSpec::isolated() const noexcept {
  return plugin_mode == PluginMode::kIsolated ||
         (plugin_mode == PluginMode::kDefault && realtime_loop && kIsolationCostsLittleUnderRealtime);
}

DeviceSpec parse_device_spec(std::string_view text) {
  DeviceSpec spec;
  if (text == "sim") return spec;
  using Mode = DeviceSpec::PluginMode;
  for (const auto& [prefix, mode] : {std::pair{std::string_view("plugin:"), Mode::kDefault},
                                     std::pair{std::string_view("plugin-inprocess:"), Mode::kInProcess},
                                     std::pair{std::string_view("plugin-isolated:"), Mode::kIsolated}}) {
    if (!text.starts_with(prefix)) continue;
    spec.kind = DeviceSpec::Kind::kPlugin;
    spec.plugin_mode = mode;
    spec.path = std::string(text.substr(prefix.size()));
    if (spec.path.empty()) fail(text, "names no plugin file");
    return spec;
  }
  if (text.starts_with("udp:")) {
    spec.kind = DeviceSpec::Kind::kUdp;
    const std::string_view rest = text.substr(4);
    const std::size_t colon = rest.rfind(':');
    if (colon == std::string_view::npos) {
      spec.host = "127.0.0.1";
      spec.port = parse_port(text, rest);
    } else {
      spec.host = std::string(rest.substr(0, colon));
      if (spec.host.empty()) fail(text, "has an empty host");
      spec.port = parse_port(text, rest.substr(colon + 1));
    }
    return spec;
  }
  fail(text, "is not a device");
}

void add_device_options(DeviceSpec& spec, const std::vector<std::string>& key_values) {
  for (const std::string& kv : key_values) {
    const std::size_t eq = kv.find('=');
    if (eq == std::string::npos || eq == 0)
      throw std::invalid_argument("device-option: '" + kv + "' is not key=value");
    const std::string key = kv.substr(0, eq);
    if (!spec.options.emplace(key, kv.substr(eq + 1)).second)
      throw std::invalid_argument("device-option: '" + key + "' is given twice");
  }
}

}  // namespace hapticlab
