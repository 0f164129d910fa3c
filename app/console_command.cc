#include "app/console_command.h"

#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/insecure_flag.h"
#include "app/interrupt_flag.h"
#include "console/console_server.h"
#include "core/device/device_factory.h"
#include "core/device/device_spec.h"
#include "core/loop/realtime.h"
#include "core/sim/trial_runner.h"

namespace hapticlab::app {
namespace {

struct ConsoleOptions {
  std::string db;
  std::string bind = "127.0.0.1";
  int port = 8080;
  std::string token_file;
  std::string device = "sim";
  std::vector<std::string> device_options;
  bool insecure = false;
  std::string clock = "virtual";
  double max_trial_s = 300.0;
  int training_trials = -1;
  bool realtime = false;
};

// 128 bits from the system's entropy source, as hex.
std::string new_token() {
  std::random_device rd;
  std::string out;
  char buf[9];
  for (int i = 0; i < 4; ++i) {
    std::snprintf(buf, sizeof buf, "%08x", static_cast<unsigned>(rd()));
    out += buf;
  }
  return out;
}

// The token in a file only its owner can read (created 0600; an existing
// one must not be readable by others).
std::string token_from_file(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if ((st.st_mode & 077) != 0)
      throw std::invalid_argument("--token-file: " + path + " is readable by others (mode " +
                                  std::to_string(st.st_mode & 0777) + " octal-decimal); chmod 600 it");
    std::ifstream in(path);
    std::string token;
    std::getline(in, token);
    if (token.size() < 16)
      throw std::invalid_argument("--token-file: " + path + " holds " + std::to_string(token.size()) +
                                  " characters, must be at least 16");
    return token;
  }
  const std::string token = new_token();
  const mode_t old = ::umask(077);
  std::ofstream out(path);
  ::umask(old);
  out << token << "\n";
  if (!out) throw std::runtime_error("--token-file: cannot write " + path);
  return token;
}

int run(const ConsoleOptions& opt) {
  console::ConsoleConfig config;
  config.session.db = opt.db;
  config.session.device = parse_device_spec(opt.device);
  add_device_options(config.session.device, opt.device_options);
  config.session.device.insecure = opt.insecure;
  // Refused now rather than at the first session (the device itself is
  // opened only then).
  check_device_spec(config.session.device);
  config.session.clock = parse_clock_kind(opt.clock);
  config.session.max_trial_s = opt.max_trial_s;
  if (opt.training_trials >= 0) config.session.training_trials = opt.training_trials;
  config.session.realtime.enabled = opt.realtime;
  if (opt.realtime) std::fprintf(stderr, "%s\n", prepare_realtime(config.session.realtime).c_str());
  config.bind_address = opt.bind;
  config.port = opt.port;
  const bool loopback = opt.bind == "127.0.0.1" || opt.bind == "localhost" || opt.bind == "::1";
  if (!loopback) {
    if (opt.token_file.empty())
      throw std::invalid_argument("--bind " + opt.bind + ": serving beyond this machine needs --token-file FILE");
    std::fprintf(stderr,
                 "warning: the console listens on %s: anyone who can reach it sees the study's progress; "
                 "controls need the token in %s. HTTP is not encrypted: use a trusted network.\n",
                 opt.bind.c_str(), opt.token_file.c_str());
  }
  config.token = opt.token_file.empty() ? token_from_file(opt.db + ".console-token") : token_from_file(opt.token_file);
  std::printf("console token (controls need it): %s  (also in %s, readable only by you)\n", config.token.c_str(),
              (opt.token_file.empty() ? opt.db + ".console-token" : opt.token_file).c_str());
  InterruptFlag interrupt;
  console::serve_console(config, interrupt.flag());
  return 0;
}

}  // namespace

void add_console_command(CLI::App& app) {
  auto opt = std::make_shared<ConsoleOptions>();
  CLI::App* cmd = app.add_subcommand(
      "console", "Operator's web console: study progress, session controls with STOP, live plots and a blinded "
                 "participant screen, in a browser (docs/console.md)");
  cmd->add_option("--db", opt->db, "Study database (hapticlab study create)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--port", opt->port, "TCP port, 0..65535 (0: any free one, printed)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  cmd->add_option("--bind", opt->bind, "Address to listen on; anything but 127.0.0.1 needs --token-file")
      ->capture_default_str();
  cmd->add_option("--token-file", opt->token_file,
                  "File with the control token (made with a new one, mode 600, if missing; default: DB.console-token)");
  cmd->add_option("--device", opt->device, "Device for sessions, as for `session run` (sim, plugin:PATH, udp:HOST:PORT)")
      ->capture_default_str();
  cmd->add_option("--device-option", opt->device_options, "key=value for the device, repeatable");
  add_insecure_flag(cmd, opt->insecure);
  cmd->add_option("--clock", opt->clock, "virtual (simulated device, as fast as it runs) or wall")
      ->check(CLI::IsMember({"virtual", "wall"}))
      ->capture_default_str();
  cmd->add_option("--max-trial-s", opt->max_trial_s, "Time limit per trial [s]")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--training-trials", opt->training_trials,
                  "Simulated training trials per task (default: the protocol's)")
      ->check(CLI::Range(0, 1000));
  cmd->add_flag("--realtime", opt->realtime,
                "Run the haptic loop with SCHED_FIFO, pinned to one CPU, memory locked, as `session run --realtime` "
                "(recommended when browsers watch on the same machine: BENCHMARKS.md)");
  cmd->callback([opt] {
    const int status = run(*opt);
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace hapticlab::app
