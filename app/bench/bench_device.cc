#include "app/bench/bench_device.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/cli/cli_checks.h"
#include "core/device/device_factory.h"
#include "core/device/hand_attachment.h"
#include "core/device/isolated_plugin_device.h"
#include "core/common/clock.h"
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
  Rig through_plugin(parse_device_spec("plugin-inprocess:" + plugin));
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

// Nearest-rank percentile of a sorted vector.
double nearest_rank(const std::vector<double>& sorted, double fraction) {
  if (sorted.empty()) return 0.0;
  const auto rank = static_cast<std::size_t>(std::ceil(fraction * static_cast<double>(sorted.size())));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

struct Spread {
  double p50_us, p99_us, max_us;
};
Spread spread(std::vector<double>& ns) {
  std::sort(ns.begin(), ns.end());
  return {nearest_rank(ns, 0.5) / 1e3, nearest_rank(ns, 0.99) / 1e3, ns.empty() ? 0.0 : ns.back() / 1e3};
}

// CPU time a process has used [s] (utime + stime of /proc/PID/stat), or -1.
double process_cpu_s(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t paren = text.rfind(')');
  if (paren == std::string::npos) return -1.0;
  std::istringstream fields(text.substr(paren + 2));
  std::string field;
  double ticks = 0.0;
  // After the name: state is field 3; utime and stime are fields 14 and 15.
  for (int k = 3; k <= 15 && fields >> field; ++k)
    if (k >= 14) ticks += std::stod(field);
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

// The isolated plugin against the same plugin in-process: one read + write
// per update, as the loop does, each update paced on the wall clock like
// the loop (sleep, then spin to the deadline) and timed alone, the two
// backends in alternating order within the same period so a noisy phase
// of the machine hits both.
void print_isolation_bench(const std::string& plugin, std::uint64_t updates, double period_us, bool json,
                           const Spread& x, const Spread& y, double host_cpu_fraction) {
  const double overhead_p99_us = y.p99_us - x.p99_us;
  const bool default_isolated = overhead_p99_us < 20.0;
  if (json) {
    std::printf("%s\n", nlohmann::json{{"benchmark", "device isolation"},
                                       {"plugin", plugin},
                                       {"updates", updates},
                                       {"period_us", period_us},
                                       {"in_process_us", {{"p50", x.p50_us}, {"p99", x.p99_us}, {"max", x.max_us}}},
                                       {"isolated_us", {{"p50", y.p50_us}, {"p99", y.p99_us}, {"max", y.max_us}}},
                                       {"overhead_p50_us", y.p50_us - x.p50_us},
                                       {"overhead_p99_us", overhead_p99_us},
                                       {"host_cpu_percent", 100.0 * host_cpu_fraction},
                                       {"under_20_us_at_p99", default_isolated}}
                            .dump(2)
                            .c_str());
    return;
  }
  std::printf("hapticlab bench device --isolation: read + write per update through %s, %llu updates paced at "
              "%.0f us on the wall clock, in-process and isolated alternating\n",
              plugin.c_str(), static_cast<unsigned long long>(updates), period_us);
  std::printf("%-28s p50 %8.2f us   p99 %8.2f us   max %9.1f us\n", "in-process (dlopen)", x.p50_us, x.p99_us,
              x.max_us);
  std::printf("%-28s p50 %8.2f us   p99 %8.2f us   max %9.1f us\n", "isolated (child process)", y.p50_us, y.p99_us,
              y.max_us);
  std::printf("isolation costs %.2f us at p50, %.2f us at p99; under 20 us at p99: %s\n", y.p50_us - x.p50_us,
              overhead_p99_us, default_isolated ? "yes" : "NO");
  std::printf("the host process used %.0f %% of a CPU (it spins around each expected call)\n",
              100.0 * host_cpu_fraction);
}

void bench_isolation(std::string plugin, std::uint64_t updates, double period_us, bool json) {
  if (plugin.empty()) plugin = default_sim_plugin();
  Rig in_process(parse_device_spec("plugin-inprocess:" + plugin));
  Rig isolated(parse_device_spec("plugin-isolated:" + plugin));
  DeviceCommand command;
  command.force[0][kJointPitch] = 1e-3;
  command.force[1][kJointPitch] = -1e-3;
  DeviceReading reading;
  std::uint64_t faults = 0;
  const auto one_update = [&](Rig& rig) {
    const auto t0 = std::chrono::steady_clock::now();
    rig.clock.sleep_until(static_cast<double>(++rig.tick) * 1e-3);
    faults += rig.device->read(reading) != DeviceStatus::kOk;
    faults += rig.device->write(command) != DeviceStatus::kOk;
    return std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count();
  };
  for (int k = 0; k < 1000; ++k) {
    one_update(in_process);
    one_update(isolated);
  }
  std::vector<double> a, b;
  a.reserve(updates);
  b.reserve(updates);
  const auto* host = dynamic_cast<const IsolatedPluginDevice*>(isolated.device.get());
  const pid_t host_pid = host != nullptr ? host->host_pid() : 0;
  const double host_cpu0_s = process_cpu_s(host_pid);
  WallClock wall;
  double next_s = wall.now_s();
  for (std::uint64_t k = 0; k < updates; ++k) {
    wall.sleep_until(next_s);
    next_s = std::max(next_s + period_us * 1e-6, wall.now_s());
    if (k % 2 == 0) {
      a.push_back(one_update(in_process));
      b.push_back(one_update(isolated));
    } else {
      b.push_back(one_update(isolated));
      a.push_back(one_update(in_process));
    }
  }
  const double host_cpu_fraction = (process_cpu_s(host_pid) - host_cpu0_s) / (wall.now_s());
  if (faults > 0) throw std::runtime_error("bench device: " + std::to_string(faults) + " device faults");
  print_isolation_bench(plugin, updates, period_us, json, spread(a), spread(b), host_cpu_fraction);
}

}  // namespace

void add_bench_device_command(CLI::App& bench) {
  struct Opts {
    std::string plugin;
    std::uint64_t updates = 50000;
    int rounds = 30;
    bool json = false;
    bool isolation = false;
    double period_us = 1000.0;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = bench.add_subcommand(
      "device", "Device plugin call overhead: read + write per update through the built-in sim and through "
                "the sim plugin (hapticlab_sim_device.so), ns per update and their difference; with --isolation, "
                "the sim plugin in-process against isolated in its own process");
  cmd->add_option("--plugin", o->plugin,
                  "The sim plugin to load (default: hapticlab_sim_device.so next to this binary)");
  cmd->add_option("--updates", o->updates, "Updates per round, 1000..100000000")
      ->check(whole_number_in(1000, 100000000))
      ->capture_default_str();
  cmd->add_option("--rounds", o->rounds, "Rounds per backend, alternating, 1..100")
      ->check(whole_number_in(1, 100))
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "Machine-readable output");
  cmd->add_flag("--isolation", o->isolation,
                "Instead: the sim plugin isolated in a child process against in-process, per update latency "
                "(p50/p99/max) over --updates updates paced at --period-us on the wall clock");
  cmd->add_option("--period-us", o->period_us, "With --isolation: the update period [us], 0..10000 (0: back to back)")
      ->check(number_in(0.0, 10000.0))
      ->capture_default_str();
  cmd->callback([o] {
    if (o->isolation) bench_isolation(o->plugin, o->updates, o->period_us, o->json);
    else bench_device(o->plugin, o->updates, o->rounds, o->json);
  });
}

}  // namespace hapticlab::app
