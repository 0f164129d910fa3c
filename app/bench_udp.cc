#include "app/bench_udp.h"

#include <atomic>
#include <cstdio>
#include <memory>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "core/device/udp_device.h"
#include "core/device/udp_sim_server.h"
#include "core/loop/clock.h"

namespace hapticlab::app {
namespace {

void bench_udp(double seconds, double rate_Hz, int port, bool json) {
  std::optional<UdpSimServer> server;
  std::atomic<bool> stop{false};
  std::thread serving;
  if (port == 0) {
    server.emplace("127.0.0.1", 0);
    port = server->port();
    serving = std::thread([&] { server->run(stop); });
  }
  struct Join {
    std::atomic<bool>& stop;
    std::thread& t;
    ~Join() {
      stop = true;
      if (t.joinable()) t.join();
    }
  } join{stop, serving};

  UdpDeviceOptions options;
  options.port = port;
  options.timeout_ms = 100;
  UdpDevice device(options);
  WallClock clock;
  if (device.configure(DeviceConfig{rate_Hz, 1}) != DeviceStatus::kOk || device.activate(clock) != DeviceStatus::kOk)
    throw std::runtime_error("bench udp: the device behind udp:127.0.0.1:" + std::to_string(port) +
                             " refused to start");
  // Zero forces and no hand: the round trip is the figure, not the physics.
  const auto updates = static_cast<long>(seconds * rate_Hz);
  const double period_s = 1.0 / rate_Hz;
  DeviceReading reading;
  const DeviceCommand zero{};
  std::uint64_t failed = 0;
  const double start_s = clock.now_s();
  for (long k = 0; k < updates; ++k) {
    clock.sleep_until(start_s + static_cast<double>(k) * period_s);
    if (device.read(reading) != DeviceStatus::kOk) ++failed;
    device.write(zero);
  }
  device.deactivate();
  const UdpDevice::Counts c = device.counts();
  const double p50_us = device.round_trip_quantile_s(0.5) * 1e6, p99_us = device.round_trip_quantile_s(0.99) * 1e6;
  if (json) {
    nlohmann::json j = {{"benchmark", "udp"}, {"rate_Hz", rate_Hz}, {"seconds", seconds},
                        {"polls", updates},   {"failed_reads", failed}, {"p50_round_trip_us", p50_us},
                        {"p99_round_trip_us", p99_us}, {"timeouts", c.timeouts}, {"stale", c.stale},
                        {"out_of_order", c.out_of_order}, {"malformed", c.malformed}};
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("hapticlab bench udp: POLL -> STATE round trip over loopback, %.0f Hz, %.1f s, %s udp:127.0.0.1:%d\n",
              rate_Hz, seconds, server ? "simulated workstation served by this process on" : "the driver at", port);
  std::printf("polls %ld, round trip p50 %.0f us, p99 %.0f us (1 us bins); target p99 < 200 us: %s\n", updates,
              p50_us, p99_us, p99_us < 200.0 ? "met" : "NOT met");
  std::printf("failed reads %llu, timeouts %llu, stale %llu, out of order %llu, malformed %llu\n",
              static_cast<unsigned long long>(failed), static_cast<unsigned long long>(c.timeouts),
              static_cast<unsigned long long>(c.stale), static_cast<unsigned long long>(c.out_of_order),
              static_cast<unsigned long long>(c.malformed));
}

}  // namespace

void add_bench_udp_command(CLI::App& bench) {
  struct Opts {
    double seconds = 10.0;
    double rate_Hz = 1000.0;
    int port = 0;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = bench.add_subcommand("udp", "Measure the UDP bridge's round trip (POLL -> STATE) over loopback");
  cmd->add_option("--seconds", o->seconds, "How long to run [s]")->check(CLI::Range(0.1, 3600.0))->capture_default_str();
  cmd->add_option("--rate-hz", o->rate_Hz, "Poll rate [Hz], 150..2000")
      ->check(CLI::Range(150.0, 2000.0))
      ->capture_default_str();
  cmd->add_option("--port", o->port, "Port of a running `device serve-sim` on 127.0.0.1 (0: serve in this process)")
      ->check(CLI::Range(0, 65535));
  cmd->add_flag("--json", o->json, "Machine-readable output");
  cmd->callback([o] { bench_udp(o->seconds, o->rate_Hz, o->port, o->json); });
}

}  // namespace hapticlab::app
