#include "app/bench_device.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "core/device/device_factory.h"
#include "core/device/hand_attachment.h"
#include "core/loop/clock.h"
#include "core/sim/participant.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

// The sim plugin next to this binary: build/plugins/ in a build tree,
// LIBDIR/hapticlab/plugins/ when installed.
std::string default_sim_plugin() {
  std::error_code ec;
  const fs::path exe_dir = fs::read_symlink("/proc/self/exe", ec).parent_path();
  for (const fs::path& candidate : {exe_dir.parent_path() / "plugins" / "hapticlab_sim_device.so",
                                    exe_dir.parent_path() / "lib" / "hapticlab" / "plugins" / "hapticlab_sim_device.so",
                                    exe_dir.parent_path() / "lib64" / "hapticlab" / "plugins" / "hapticlab_sim_device.so"})
    if (fs::is_regular_file(candidate, ec)) return candidate.string();
  throw std::runtime_error("bench device: hapticlab_sim_device.so not found next to this binary; give --plugin PATH");
}

// One backend, opened as a session opens it, resting at the participant's
// start pose with the hand released.
struct Rig {
  explicit Rig(const DeviceSpec& spec) : device(open_device(spec)) {
    if (device->configure(DeviceConfig{1000.0, 1}) != DeviceStatus::kOk)
      throw std::runtime_error("bench device: " + spec.describe() + " refused its configuration");
    if (HandAttachment* hand = device->hand_attachment())
      for (int i = 0; i < 2; ++i) hand->set_start_pose(i, Participant::start_pose(i));
    if (device->activate(clock) != DeviceStatus::kOk)
      throw std::runtime_error("bench device: " + spec.describe() + " refused to activate");
  }
  ~Rig() { device->deactivate(); }
  VirtualClock clock;
  std::unique_ptr<Device> device;
  std::uint64_t tick = 0;
};

// ns per update of `updates` read+write pairs. The command is small and
// constant: the motor path runs, the device does not hit an end stop
// differently from one round to the next in a way that changes the cost.
double time_updates(Rig& rig, std::uint64_t updates) {
  DeviceCommand command;
  command.force[0][kJointPitch] = 1e-3;
  command.force[1][kJointPitch] = -1e-3;
  DeviceReading reading;
  std::uint64_t faults = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (std::uint64_t k = 0; k < updates; ++k) {
    rig.clock.sleep_until(static_cast<double>(++rig.tick) * 1e-3);
    faults += rig.device->read(reading) != DeviceStatus::kOk;
    faults += rig.device->write(command) != DeviceStatus::kOk;
  }
  const double ns = std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
  if (faults > 0) throw std::runtime_error("bench device: " + std::to_string(faults) + " device faults");
  return ns / static_cast<double>(updates);
}

void bench_device(std::string plugin, std::uint64_t updates, int rounds, bool json) {
  if (plugin.empty()) plugin = default_sim_plugin();
  Rig sim(parse_device_spec("sim"));
  Rig through_plugin(parse_device_spec("plugin:" + plugin));
  // Warm both (caches, page faults of the plugin's code), then alternate
  // so a slow phase of the machine hits both alike; the best round of each
  // is the cost without interference.
  time_updates(sim, updates / 10 + 1);
  time_updates(through_plugin, updates / 10 + 1);
  double best_sim = std::numeric_limits<double>::infinity(), best_plugin = best_sim;
  for (int r = 0; r < rounds; ++r) {
    best_sim = std::min(best_sim, time_updates(sim, updates));
    best_plugin = std::min(best_plugin, time_updates(through_plugin, updates));
  }
  const double overhead = best_plugin - best_sim;
  if (json) {
    std::printf("%s\n", nlohmann::json{{"benchmark", "device"},
                                       {"plugin", plugin},
                                       {"updates_per_round", updates},
                                       {"rounds", rounds},
                                       {"sim_ns_per_update", best_sim},
                                       {"plugin_ns_per_update", best_plugin},
                                       {"overhead_ns_per_update", overhead},
                                       {"ratio", best_plugin / best_sim}}
                            .dump(2)
                            .c_str());
    return;
  }
  std::printf("hapticlab bench device: read + write per update, virtual clock at 1 kHz, %llu updates x %d rounds "
              "per backend (best round)\n",
              static_cast<unsigned long long>(updates), rounds);
  std::printf("%-28s %10.1f ns/update\n", "sim (built in)", best_sim);
  std::printf("%-28s %10.1f ns/update  (%s)\n", "sim plugin (C ABI, dlopen)", best_plugin, plugin.c_str());
  std::printf("plugin overhead %.1f ns/update (ratio %.3f); goal < 100 ns: %s\n", overhead, best_plugin / best_sim,
              overhead < 100.0 ? "met" : "NOT met");
}

}  // namespace

void add_bench_device_command(CLI::App& bench) {
  struct Opts {
    std::string plugin;
    std::uint64_t updates = 50000;
    int rounds = 30;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = bench.add_subcommand(
      "device", "Device plugin call overhead: read + write per update through the built-in sim and through "
                "the sim plugin (hapticlab_sim_device.so), ns per update and their difference");
  cmd->add_option("--plugin", o->plugin,
                  "The sim plugin to load (default: hapticlab_sim_device.so next to this binary)");
  cmd->add_option("--updates", o->updates, "Updates per round, 1000..100000000")
      ->check(CLI::Range(std::uint64_t{1000}, std::uint64_t{100000000}))
      ->capture_default_str();
  cmd->add_option("--rounds", o->rounds, "Rounds per backend, alternating, 1..100")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "Machine-readable output");
  cmd->callback([o] { bench_device(o->plugin, o->updates, o->rounds, o->json); });
}

}  // namespace hapticlab::app
