#include "app/device/device_command.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/cli/cli_checks.h"
#include "app/cli/insecure_flag.h"
#include "app/cli/option_shapes.h"
#include "core/device/device_factory.h"
#include "core/device/hand_attachment.h"
#include "core/device/isolated_plugin_device.h"
#include "core/device/plugin_device.h"
#include "core/common/clock.h"
#include "core/loop/rate_monitor.h"
#include "core/sim/participant.h"
#include "core/common/csv_format.h"

namespace hapticlab::app {
namespace {

constexpr int kExitDeviceFault = 3;  // as `session run`
constexpr const char* kJointNames[kNumDeviceJoints] = {"insertion", "pitch", "yaw", "twist", "grip"};
constexpr const char* kInstrumentNames[2] = {"left", "right"};

const char* position_unit(int joint) { return joint == kJointInsertion ? "m" : "rad"; }
const char* force_unit(int joint) { return joint == kJointInsertion ? "N" : "N*m"; }

struct CheckOptions {
  std::string device;
  std::vector<std::string> device_options;
  bool insecure = false;
  double seconds = 2.0;
  double rate_Hz = 1000.0;
  double rate_tolerance_fraction = RateCheck::kDefaultToleranceFraction;
  bool json = false;
};

// What the loop saw, per instrument and joint.
struct Seen {
  double min = std::numeric_limits<double>::infinity();
  double max = -std::numeric_limits<double>::infinity();
};

struct CheckResult {
  std::uint64_t updates = 0;
  double elapsed_s = 0.0;
  std::vector<double> dt_s;
  std::array<std::array<Seen, kNumDeviceJoints>, 2> seen{};
  std::array<std::uint64_t, kNumDeviceStatuses> read_faults{};
  std::array<std::uint64_t, kNumDeviceStatuses> write_faults{};
  std::uint64_t outside_rating = 0;  // ok readings outside [min_position, max_position]
  std::uint64_t over_velocity = 0;   // ok readings implying a speed above max_velocity
  // The first window (up to 1 s, as in a session) whose achieved rate left
  // the tolerance: a device too slow for the rate asked of it.
  std::optional<RateViolation> rate_violation;
  // An isolated plugin's process crashed or hung: the check ends there
  // ("device_crashed: SIGSEGV in read"). Empty otherwise.
  std::string process_fault;

  double achieved_Hz() const { return elapsed_s > 0.0 ? static_cast<double>(updates - 1) / elapsed_s : 0.0; }
  std::uint64_t faults() const {
    std::uint64_t n = outside_rating + over_velocity + (rate_violation ? 1 : 0);
    for (std::uint64_t c : read_faults) n += c;
    for (std::uint64_t c : write_faults) n += c;
    return n;
  }
};

// Nearest-rank percentile of a sorted vector.
double percentile(const std::vector<double>& sorted, double fraction) {
  if (sorted.empty()) return 0.0;
  const auto rank = static_cast<std::size_t>(std::ceil(fraction * static_cast<double>(sorted.size())));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

// The loop of the check: read, zero force, at the rate on the wall clock,
// for opt.seconds of it (a device too slow for the rate runs fewer
// updates, not longer). Like the haptic loop it never bursts to catch up
// after a late update, and checks the achieved rate as a session does.
// One good reading against the ratings: the range seen, positions outside
// the rating, and moves faster than the rating since `previous` (when set).
inline void check_reading(const DeviceReading& reading, const DeviceReading* previous, const DeviceRatings& ratings,
                          double now_s, double previous_s, CheckResult& r) {
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const auto ui = static_cast<std::size_t>(i), uj = static_cast<std::size_t>(j);
      const double x = reading.position[ui][uj];
      const DeviceJointRating& rating = ratings.joint[ui][uj];
      Seen& s = r.seen[ui][uj];
      s.min = std::min(s.min, x);
      s.max = std::max(s.max, x);
      if (x < rating.min_position || x > rating.max_position) ++r.outside_rating;
      if (previous != nullptr &&
          std::abs(x - previous->position[ui][uj]) > rating.max_velocity * (now_s - previous_s))
        ++r.over_velocity;
    }
}

// The whole run, for one shorter than a window (or the part after the
// last); not one a crashed or hung device cut short, whose last period
// holds the hang.
void finish_checks(const CheckOptions& opt, CheckResult& r) {
  const double achieved_Hz = r.achieved_Hz();
  if (!r.rate_violation && r.process_fault.empty() && r.updates > 1 &&
      std::abs(achieved_Hz / opt.rate_Hz - 1.0) > opt.rate_tolerance_fraction)
    r.rate_violation = RateViolation{achieved_Hz, opt.rate_Hz, r.elapsed_s, opt.rate_tolerance_fraction};
  std::sort(r.dt_s.begin(), r.dt_s.end());
}

CheckResult run_checks(Device& device, const DeviceRatings& ratings, WallClock& clock, const CheckOptions& opt) {
  CheckResult r;
  const double period_s = 1.0 / opt.rate_Hz;
  r.dt_s.reserve(static_cast<std::size_t>(std::llround(opt.seconds * opt.rate_Hz)) + 1);
  const DeviceCommand zero{};
  DeviceReading previous{};
  bool have_previous = false;
  RateMonitor rate(RateCheck{opt.rate_tolerance_fraction, std::min(RateCheck::kDefaultWindow_s, opt.seconds)});
  double next_s = clock.now_s(), first_s = next_s, previous_s = next_s;
  for (std::uint64_t k = 0;; ++k) {
    clock.sleep_until(next_s);
    const double now_s = clock.now_s();
    next_s = std::max(next_s + period_s, now_s);
    if (k == 0) {
      first_s = now_s;
      rate.start(now_s);
    } else {
      if (now_s - first_s >= opt.seconds - 0.5 * period_s) break;
      r.dt_s.push_back(now_s - previous_s);
      if (rate.update(now_s, period_s) && !r.rate_violation) r.rate_violation = rate.violation();
    }

    DeviceReading reading;
    const DeviceStatus status = device.read(reading);
    if (status == DeviceStatus::kOk) {
      check_reading(reading, have_previous ? &previous : nullptr, ratings, now_s, previous_s, r);
      previous = reading;
      have_previous = true;
    } else {
      ++r.read_faults[static_cast<std::size_t>(status)];
      have_previous = false;
    }
    const DeviceStatus written = status == DeviceStatus::kDeviceCrashed || status == DeviceStatus::kDeviceHung
                                     ? status  // nothing more is sent to a dead process
                                     : device.write(zero);
    if (written != DeviceStatus::kOk && written != status)
      ++r.write_faults[static_cast<std::size_t>(written)];
    previous_s = now_s;
    ++r.updates;
    if (written == DeviceStatus::kDeviceCrashed || written == DeviceStatus::kDeviceHung) {
      r.process_fault = device.fault_detail();
      break;
    }
  }
  r.elapsed_s = previous_s - first_s;
  finish_checks(opt, r);
  return r;
}

std::string fault_list(const CheckResult& r) {
  std::string s;
  const auto add = [&](const std::string& item) { s += (s.empty() ? "" : ", ") + item; };
  for (int k = 0; k < kNumDeviceStatuses; ++k) {
    if (r.read_faults[static_cast<std::size_t>(k)] > 0)
      add("read " + std::string(to_string(static_cast<DeviceStatus>(k))) + " " +
          std::to_string(r.read_faults[static_cast<std::size_t>(k)]));
    if (r.write_faults[static_cast<std::size_t>(k)] > 0)
      add("write " + std::string(to_string(static_cast<DeviceStatus>(k))) + " " +
          std::to_string(r.write_faults[static_cast<std::size_t>(k)]));
  }
  if (r.outside_rating > 0) add("reading outside the rated range " + std::to_string(r.outside_rating));
  if (r.over_velocity > 0) add("faster than max_velocity " + std::to_string(r.over_velocity));
  if (r.rate_violation) {
    char text[200];
    const RateViolation& v = *r.rate_violation;
    std::snprintf(text, sizeof text,
                  "rate_violation: %.1f Hz achieved where %.0f Hz was asked (%+.1f %%, tolerance %.1f %%, over "
                  "%.2f s)",
                  v.achieved_Hz, v.asked_Hz, 100.0 * (v.achieved_Hz / v.asked_Hz - 1.0), 100.0 * v.tolerance_fraction,
                  v.window_s);
    add(text);
  }
  return s.empty() ? "none" : s;
}

void print_text(const DeviceSpec& spec, const Device& device, const DeviceRatings& ratings, const CheckResult& r,
                const CheckOptions& opt) {
  std::printf("hapticlab device check: %s (%s), %s s at %.0f Hz on the wall clock, zero force commanded\n",
              spec.describe().c_str(), device.name(), format_number(opt.seconds).c_str(), opt.rate_Hz);
  std::printf("ratings:\n  %-5s %-9s %24s %22s %14s\n", "", "joint", "range", "continuous / peak", "max velocity");
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const DeviceJointRating& x = ratings.joint[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      std::printf("  %-5s %-9s [%9.4g, %9.4g] %-3s %9.4g / %-7.4g %-3s %9.4g %s/s\n", kInstrumentNames[i],
                  kJointNames[j], x.min_position, x.max_position, position_unit(j), x.continuous_force, x.peak_force,
                  force_unit(j), x.max_velocity, position_unit(j));
    }
  const double nominal_us = 1e6 / opt.rate_Hz;
  std::printf("rate: %.1f Hz achieved over %llu updates (nominal %.0f Hz, tolerance %.1f %%)\n", r.achieved_Hz(),
              static_cast<unsigned long long>(r.updates), opt.rate_Hz, 100.0 * opt.rate_tolerance_fraction);
  const double p99_us = percentile(r.dt_s, 0.99) * 1e6;
  std::printf("dt: p50 %.1f us, p99 %.1f us, max %.1f us; jitter (p99 - nominal) %.1f us\n",
              percentile(r.dt_s, 0.5) * 1e6, p99_us, r.dt_s.empty() ? 0.0 : r.dt_s.back() * 1e6,
              p99_us - nominal_us);
  std::printf("joint ranges seen (readings without a fault):\n");
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const Seen& s = r.seen[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      if (s.min > s.max) std::printf("  %-5s %-9s no reading\n", kInstrumentNames[i], kJointNames[j]);
      else
        std::printf("  %-5s %-9s %.6g .. %.6g %s (span %.3g)\n", kInstrumentNames[i], kJointNames[j], s.min, s.max,
                    position_unit(j), s.max - s.min);
    }
  std::printf("faults: %s\n", fault_list(r).c_str());
  if (!r.process_fault.empty()) std::printf("stopped after %llu updates: %s\n",
                                            static_cast<unsigned long long>(r.updates), r.process_fault.c_str());
}

void print_json(const DeviceSpec& spec, const Device& device, const DeviceRatings& ratings, const CheckResult& r,
                const CheckOptions& opt) {
  nlohmann::json rated = nlohmann::json::array(), seen = nlohmann::json::array();
  for (int i = 0; i < 2; ++i) {
    nlohmann::json rated_i = nlohmann::json::array(), seen_i = nlohmann::json::array();
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const DeviceJointRating& x = ratings.joint[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      rated_i.push_back({{"joint", kJointNames[j]}, {"min_position", x.min_position}, {"max_position", x.max_position},
                         {"continuous_force", x.continuous_force}, {"peak_force", x.peak_force},
                         {"max_velocity", x.max_velocity}});
      const Seen& s = r.seen[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      seen_i.push_back(s.min > s.max ? nlohmann::json{{"joint", kJointNames[j]}}
                                     : nlohmann::json{{"joint", kJointNames[j]}, {"min", s.min}, {"max", s.max}});
    }
    rated.push_back(rated_i);
    seen.push_back(seen_i);
  }
  nlohmann::json read_faults = nlohmann::json::object(), write_faults = nlohmann::json::object();
  for (int k = 0; k < kNumDeviceStatuses; ++k) {
    const char* name = to_string(static_cast<DeviceStatus>(k));
    if (r.read_faults[static_cast<std::size_t>(k)] > 0) read_faults[name] = r.read_faults[static_cast<std::size_t>(k)];
    if (r.write_faults[static_cast<std::size_t>(k)] > 0) write_faults[name] = r.write_faults[static_cast<std::size_t>(k)];
  }
  const double achieved_Hz = r.achieved_Hz();
  const nlohmann::json j = {
      {"device", spec.describe()},
      {"name", device.name()},
      {"seconds", opt.seconds},
      {"nominal_rate_Hz", opt.rate_Hz},
      {"updates", r.updates},
      {"achieved_rate_Hz", achieved_Hz},
      {"dt_us",
       {{"p50", percentile(r.dt_s, 0.5) * 1e6},
        {"p99", percentile(r.dt_s, 0.99) * 1e6},
        {"max", r.dt_s.empty() ? 0.0 : r.dt_s.back() * 1e6}}},
      {"ratings", rated},
      {"seen", seen},
      {"faults",
       {{"read", read_faults},
        {"write", write_faults},
        {"outside_rating", r.outside_rating},
        {"over_velocity", r.over_velocity},
        {"rate_violation", r.rate_violation ? nlohmann::json{{"achieved_Hz", r.rate_violation->achieved_Hz},
                                                              {"asked_Hz", r.rate_violation->asked_Hz},
                                                              {"window_s", r.rate_violation->window_s},
                                                              {"tolerance_fraction",
                                                               r.rate_violation->tolerance_fraction}}
                                            : nlohmann::json()},
        {"total", r.faults()}}},
      {"process_fault", r.process_fault.empty() ? nlohmann::json() : nlohmann::json(r.process_fault)}};
  std::printf("%s\n", j.dump(2).c_str());
}

int run_check(const CheckOptions& opt) {
  DeviceSpec spec = parse_device_spec(opt.device);
  add_device_options(spec, opt.device_options);
  spec.insecure = opt.insecure;
  const DeviceConfig config{opt.rate_Hz, 0};
  // A plugin that crashes does it in a child process, with a message.
  probe_device(spec, config);
  const std::unique_ptr<Device> device = open_device(spec);

  if (const DeviceStatus status = device->configure(config); status != DeviceStatus::kOk) {
    std::string plugin_error;
    if (const auto* plugin = dynamic_cast<const PluginDevice*>(device.get())) plugin_error = plugin->configure_error();
    if (const auto* plugin = dynamic_cast<const IsolatedPluginDevice*>(device.get()))
      plugin_error = plugin->configure_error();
    std::fprintf(stderr, "hapticlab device check: %s\n",
                 !plugin_error.empty()
                     ? plugin_error.c_str()
                     : ("the " + spec.describe() + " device refused its configuration (" + to_string(status) +
                        ") at " + std::to_string(opt.rate_Hz) + " Hz")
                           .c_str());
    return kExitDeviceFault;
  }
  const DeviceRatings ratings = device->ratings();
  // A simulated device rests where the simulated participant would start;
  // nobody holds it.
  if (HandAttachment* hand = device->hand_attachment())
    for (int i = 0; i < 2; ++i) hand->set_start_pose(i, Participant::start_pose(i));

  WallClock clock;
  if (const DeviceStatus status = device->activate(clock); status != DeviceStatus::kOk) {
    if (status == DeviceStatus::kNotCalibrated)
      std::fprintf(stderr, "hapticlab device check: the %s device reports that it is not calibrated or homed "
                           "(not_calibrated); calibrate or home it as its maker describes, then run the check "
                           "again. Nothing was driven.\n", spec.describe().c_str());
    else
      std::fprintf(stderr, "hapticlab device check: the %s device refused to activate (%s). Nothing was driven.\n",
                   spec.describe().c_str(), to_string(status));
    device->deactivate();
    return kExitDeviceFault;
  }
  const CheckResult r = run_checks(*device, ratings, clock, opt);
  device->deactivate();

  if (opt.json) print_json(spec, *device, ratings, r, opt);
  else print_text(spec, *device, ratings, r, opt);
  if (!r.process_fault.empty()) {
    std::fprintf(stderr, "hapticlab device check: %s after %llu updates; the check stopped there (it "
                         "commanded zero force throughout)\n",
                 r.process_fault.c_str(), static_cast<unsigned long long>(r.updates));
    return kExitDeviceFault;
  }
  if (r.faults() > 0) {
    std::fprintf(stderr, "hapticlab device check: %llu fault%s in %llu updates (%s); fix them before running a "
                         "session on this device\n",
                 static_cast<unsigned long long>(r.faults()), r.faults() == 1 ? "" : "s",
                 static_cast<unsigned long long>(r.updates), fault_list(r).c_str());
    return kExitDeviceFault;
  }
  return 0;
}

}  // namespace

void add_device_check_command(CLI::App& device) {
  auto opt = std::make_shared<CheckOptions>();
  CLI::App* cmd = device.add_subcommand(
      "check",
      "Open a device, read it at the loop rate on the wall clock while commanding zero force, and print its "
      "name, ratings, the rate achieved, dt jitter, the joint ranges seen and the faults. Run this first on a "
      "new device. Exit status 0 if it worked throughout, 3 if it refused its configuration or activation or "
      "had a fault, 1 if it could not be opened (no such plugin, no device answering, invalid ratings).");
  cmd->add_option("--device", opt->device,
                  "Device: sim, plugin:PATH.so (docs/devices.md), plugin-isolated:PATH.so (in a process of its "
                  "own: a crash or hang is reported, exit status 3), udp:[HOST:]PORT (docs/udp_bridge.md)")
      ->required();
  cmd->add_option("--device-option", opt->device_options, "key=value passed to the device (repeatable)");
  add_insecure_flag(cmd, opt->insecure);
  cmd->add_option("--seconds", opt->seconds, "How long to read [s], 0.05..3600")
      ->check(number_in(0.05, 3600.0))
      ->capture_default_str();
  add_loop_rate_option(*cmd, opt->rate_Hz, "Loop rate [Hz], 150..2000")
      ->capture_default_str();
  cmd->add_option("--rate-tolerance", opt->rate_tolerance_fraction,
                  "How far the achieved rate may stray from --rate-hz (fraction, 0.001..0.5; a session takes its "
                  "protocol's rate_tolerance_fraction)")
      ->check(number_in(0.001, 0.5))
      ->capture_default_str();
  cmd->add_flag("--json", opt->json, "Machine-readable output");
  cmd->callback([opt] {
    const int status = run_check(*opt);
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace hapticlab::app
