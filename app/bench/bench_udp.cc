#include "app/bench/bench_udp.h"

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "app/cli/cli_checks.h"
#include "app/cli/insecure_flag.h"
#include "app/cli/option_shapes.h"
#include "core/device/udp_device.h"
#include "core/device/udp_sim_server.h"
#include "core/common/clock.h"

namespace hapticlab::app {
namespace {

struct BenchUdpOptions {
  double seconds = 10.0;
  double rate_Hz = 1000.0;
  std::string host = "127.0.0.1";
  int port = 0;
  std::string key_file;
  bool insecure = false;
  bool json = false;
};

// What the round trips of a run measured.
struct UdpRoundTrips {
  long updates = 0;
  std::uint64_t failed = 0;
  UdpDevice::Counts counts;
  double p50_us = 0.0, p99_us = 0.0;
  bool authenticated = false;
};

// Polls the device behind udp:HOST:PORT at the rate for the seconds.
UdpRoundTrips udp_round_trips(const BenchUdpOptions& o, int port) {
  UdpDeviceOptions options;
  options.host = o.host;
  options.port = port;
  options.timeout_ms = 100;
  options.key_file = o.key_file;
  options.insecure = o.insecure;
  UdpDevice device(options);
  WallClock clock;
  if (device.configure(DeviceConfig{o.rate_Hz, 1}) != DeviceStatus::kOk || device.activate(clock) != DeviceStatus::kOk)
    throw std::runtime_error("bench udp: the device behind udp:" + o.host + ":" + std::to_string(port) +
                             " refused to start");
  // Zero forces and no hand: the round trip is the figure, not the physics.
  UdpRoundTrips r;
  r.updates = static_cast<long>(o.seconds * o.rate_Hz);
  const double period_s = 1.0 / o.rate_Hz;
  DeviceReading reading;
  const DeviceCommand zero{};
  const double start_s = clock.now_s();
  for (long k = 0; k < r.updates; ++k) {
    clock.sleep_until(start_s + static_cast<double>(k) * period_s);
    if (device.read(reading) != DeviceStatus::kOk) ++r.failed;
    device.write(zero);
  }
  device.deactivate();
  r.counts = device.counts();
  r.p50_us = device.round_trip_quantile_s(0.5) * 1e6;
  r.p99_us = device.round_trip_quantile_s(0.99) * 1e6;
  r.authenticated = device.authenticated();
  return r;
}

// What the MACs cost this CPU, apart from the network: a STATE (the
// largest datagram of an update) made and checked, two of the four MACs
// of a round trip; a POLL's two take about a third of that.
double state_mac_us(const udp::Key& key) {
  constexpr int kMacReps = 20000;
  std::array<std::byte, udp::kMaxDatagramBytes> buffer;
  udp::State state;
  std::uint64_t checked = 0;
  const auto mac_start = std::chrono::steady_clock::now();
  for (int k = 0; k < kMacReps; ++k) {
    const std::size_t n = udp::encode(udp::Header{udp::Type::kState, static_cast<std::uint32_t>(k), 0.0, 1, 2}, state,
                                      key, buffer.data());
    udp::Header h;
    checked += udp::decode_header(buffer.data(), n, key, h) == udp::Verdict::kOk ? 1 : 0;
  }
  const double us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - mac_start).count() / kMacReps;
  if (checked != kMacReps) throw std::logic_error("bench udp: a STATE this process made failed its own check");
  return us;
}

void print_udp_bench(const BenchUdpOptions& o, int port, bool served, const UdpRoundTrips& r, double mac_us) {
  const UdpDevice::Counts& c = r.counts;
  if (o.json) {
    nlohmann::json j = {{"benchmark", "udp"}, {"rate_Hz", o.rate_Hz}, {"seconds", o.seconds},
                        {"polls", r.updates},   {"failed_reads", r.failed}, {"p50_round_trip_us", r.p50_us},
                        {"p99_round_trip_us", r.p99_us}, {"timeouts", c.timeouts}, {"stale", c.stale},
                        {"out_of_order", c.out_of_order}, {"malformed", c.malformed},
                        {"authenticated", r.authenticated}, {"rejected_mac", c.rejected_mac},
                        {"wrong_nonce", c.wrong_nonce}, {"wrong_source", c.wrong_source},
                        {"state_encode_and_check_us", mac_us}};
    std::printf("%s\n", j.dump(2).c_str());
    return;
  }
  std::printf("hapticlab bench udp: POLL -> STATE round trip, %.0f Hz, %.1f s, %s udp:%s:%d, %s\n", o.rate_Hz,
              o.seconds, served ? "simulated workstation served by this process on" : "the driver at", o.host.c_str(),
              port, r.authenticated ? "authenticated (HMAC-SHA-256)" : "not authenticated");
  std::printf("polls %ld, round trip p50 %.0f us, p99 %.0f us (1 us bins); target p99 < 200 us: %s\n", r.updates,
              r.p50_us, r.p99_us, r.p99_us < 200.0 ? "met" : "NOT met");
  std::printf("a STATE made and checked (2 HMAC-SHA-256, %zu bytes each) %.2f us on this CPU\n",
              udp::kHeaderBytes + udp::kStatePayload, mac_us);
  std::printf("failed reads %llu, timeouts %llu, stale %llu, out of order %llu, malformed %llu, rejected: bad MAC "
              "%llu, wrong nonce %llu, wrong source %llu\n",
              static_cast<unsigned long long>(r.failed), static_cast<unsigned long long>(c.timeouts),
              static_cast<unsigned long long>(c.stale), static_cast<unsigned long long>(c.out_of_order),
              static_cast<unsigned long long>(c.malformed), static_cast<unsigned long long>(c.rejected_mac),
              static_cast<unsigned long long>(c.wrong_nonce), static_cast<unsigned long long>(c.wrong_source));
}

void bench_udp(const BenchUdpOptions& o) {
  int port = o.port;
  const udp::Key key = o.key_file.empty() ? udp::Key{} : udp::read_key_file(o.key_file, "--key-file");
  std::optional<UdpSimServer> server;
  std::atomic<bool> stop{false};
  std::thread serving;
  if (port == 0) {
    if (o.host != "127.0.0.1")
      throw std::invalid_argument("--host " + o.host + ": without --port the bench serves the simulated workstation "
                                  "itself, on 127.0.0.1; give --port of the driver at " + o.host);
    server.emplace("127.0.0.1", 0, key);
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
  const UdpRoundTrips r = udp_round_trips(o, port);
  const double mac_us = state_mac_us(key);
  print_udp_bench(o, port, server.has_value(), r, mac_us);
}

}  // namespace

void add_bench_udp_command(CLI::App& bench) {
  auto o = std::make_shared<BenchUdpOptions>();
  CLI::App* cmd = bench.add_subcommand("udp", "Measure the UDP bridge's round trip (POLL -> STATE), over loopback "
                                              "or to a driver on the network");
  cmd->add_option("--seconds", o->seconds, "How long to run [s]")->check(number_in(0.1, 3600.0))->capture_default_str();
  add_loop_rate_option(*cmd, o->rate_Hz, "Poll rate [Hz], 150..2000")
      ->capture_default_str();
  cmd->add_option("--port", o->port,
                  "Port of a running `device serve-sim` or driver (0: serve the simulated workstation in this process)")
      ->check(whole_number_in(0, 65535));
  cmd->add_option("--host", o->host, "IPv4 address of the driver (with --port)")->capture_default_str();
  cmd->add_option("--key-file", o->key_file,
                  "The bridge's shared key (as --device-option key_file=PATH); without --port the served "
                  "workstation uses it too");
  add_insecure_flag(cmd, o->insecure);
  cmd->add_flag("--json", o->json, "Machine-readable output");
  cmd->callback([o] { bench_udp(*o); });
}

}  // namespace hapticlab::app
