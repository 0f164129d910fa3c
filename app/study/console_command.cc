#include "app/study/console_command.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "app/cli/cli_checks.h"
#include "app/cli/insecure_flag.h"
#include "app/cli/option_shapes.h"
#include "app/cli/interrupt_flag.h"
#include "app/cli/population_option.h"
#include "app/study/console_bind.h"
#include "console/console_server.h"
#include "core/common/secret_file.h"
#include "core/device/device_factory.h"
#include "core/device/device_spec.h"
#include "core/loop/realtime.h"
#include "core/sim/trial_runner.h"
#include "db/sqlite_handle.h"
#include "db/study_file_probe.h"

namespace hapticlab::app {
namespace {

struct ConsoleOptions {
  std::string db;
  std::string bind = "127.0.0.1";
  int port = 8080;
  int participant_port = 0;
  std::string token_file;
  std::string device = "sim";
  std::vector<std::string> device_options;
  bool insecure = false;
  std::string clock = "virtual";
  double rate_Hz = 1000.0;
  double max_trial_s = 300.0;
  int training_trials = -1;
  bool realtime = false;
  std::string population;  // --population (app/cli/population_option.h)
};

// The token of `path`, read with the checks every secret file gets
// (core/common/secret_file.h: mode 600, one line, no spaces or control
// characters, not one repeated character); a missing file is made with a
// new token (128 bits from the kernel).
std::string token_from_file(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) create_secret_file(path, random_hex(16));
  return read_secret_file(path, "--token-file");
}

// Everything the console can refuse before it writes anything: a refused
// start-up leaves the study's directory exactly as it was (no token file,
// no database made of a file that is none).
void check_before_writing(const ConsoleOptions& opt, const console::ConsoleConfig& config) {
  // Refused now rather than at the first session (the device itself is
  // opened only then).
  check_device_spec(config.session.device);
  if (opt.port != 0 && opt.port == opt.participant_port)
    throw CLI::ValidationError("--participant-port " + std::to_string(opt.participant_port),
                               "the same port as --port; the participant screen needs a port of its own, so the "
                               "participant's browser cannot read the operator's pages (0: any free one)");
  const bool loopback = console_bind_is_loopback(opt.bind);
  if (!loopback && opt.token_file.empty())
    throw CLI::ValidationError("--bind " + opt.bind, "serving beyond this machine needs --token-file FILE");
  // Opened read-only, as `study show` does: the console itself opens it
  // read-write, which would make an empty file an SQLite database. Last,
  // because a read-only connection to a study leaves its -wal and -shm.
  try {
    db::refuse_unless_study(opt.db);
  } catch (const db::DbError& e) {
    throw std::runtime_error(std::string("--db: ") + e.what());
  }
  // What is true of it (docs/console.md, "Security"): without the token
  // only the page's shell and the participant screen are served.
  if (!loopback)
    std::fprintf(stderr,
                 "warning: the console listens on %s: anyone who can reach it gets the operator page's empty shell "
                 "and the participant screen; the study's data and every control need the token in %s. HTTP is "
                 "not encrypted: the token and the data cross the network readable, so use a trusted network.\n",
                 opt.bind.c_str(), opt.token_file.c_str());
}

int run(const ConsoleOptions& opt) {
  console::ConsoleConfig config;
  config.session.db = opt.db;
  config.session.device = parse_device_spec(opt.device);
  add_device_options(config.session.device, opt.device_options);
  config.session.device.insecure = opt.insecure;
  config.session.clock = parse_clock_kind(opt.clock);
  config.session.rate_Hz = opt.rate_Hz;
  config.session.max_trial_s = opt.max_trial_s;
  if (opt.training_trials >= 0) config.session.training_trials = opt.training_trials;
  config.session.realtime.enabled = opt.realtime;
  // As `session run`: a study's simulated participants are drawn from one
  // population whichever command runs their sessions.
  config.session.population = choose_population(opt.population).point;
  check_before_writing(opt, config);
  if (opt.realtime) {
    RealtimeResult granted;
    std::fprintf(stderr, "%s\n", prepare_realtime(config.session.realtime, &granted).c_str());
    // Under SCHED_FIFO an isolated plugin costs under 20 µs per update: "plugin:" runs isolated then.
    config.session.device.realtime_loop = granted.scheduled;
  }
  config.bind_address = opt.bind;
  config.port = opt.port;
  config.participant_port = opt.participant_port;
  config.token_file = opt.token_file.empty() ? opt.db + ".console-token" : opt.token_file;
  std::error_code ec;
  const bool token_existed = std::filesystem::exists(config.token_file, ec);
  config.token = token_from_file(config.token_file.string());
  InterruptFlag interrupt;
  console::ConsoleOutcome outcome;
  try {
    outcome = console::serve_console(config, interrupt.flag());
  } catch (const std::runtime_error& e) {
    // A console that could not listen (a port in use) promised no address
    // with this token: a token file this run made goes, so the refusal
    // leaves the directory as it found it.
    if (!token_existed && std::string_view(e.what()).find("): cannot listen on ") != std::string_view::npos)
      std::filesystem::remove(config.token_file, ec);
    throw;
  }
  if (outcome.device_hung) {
    std::fprintf(stderr,
                 "hapticlab console: the device hung (%s); restart the device before the next session\n",
                 outcome.device_hung->c_str());
    std::fflush(nullptr);
    // A thread is still inside the device's code: ending the process the
    // usual way would wait for it, or destroy what it is using.
    std::_Exit(3);
  }
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
      ->check(whole_number_in(0, 65535))
      ->capture_default_str();
  cmd->add_option("--participant-port", opt->participant_port,
                  "TCP port of the participant screen, 0..65535 (0: any free one, printed); a port of its own, so "
                  "the participant's browser cannot read the operator's pages, which name the setting")
      ->check(whole_number_in(0, 65535))
      ->capture_default_str();
  cmd->add_option("--bind", opt->bind,
                  "Numeric IP address (or localhost) to listen on; one outside 127.0.0.0/8 and ::1 needs --token-file")
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
  add_loop_rate_option(*cmd, opt->rate_Hz, "Haptic loop rate of the sessions and the free trial [Hz], 150..2000, "
                                           "as `session run --rate-hz`")
      ->capture_default_str();
  add_trial_limit_option(*cmd, opt->max_trial_s, "Time limit per trial [s], 1..3600, as session run's")
      ->capture_default_str();
  cmd->add_option("--training-trials", opt->training_trials,
                  "Simulated training trials per task (default: the protocol's)")
      ->check(whole_number_in(0, 1000));
  add_population_option(cmd, opt->population);
  cmd->add_flag("--realtime", opt->realtime,
                "Run the haptic loop with SCHED_FIFO, pinned to one CPU, memory locked, as `session run --realtime` "
                "(recommended when browsers watch on the same machine: BENCHMARKS.md)");
  cmd->callback([opt] {
    const int status = run(*opt);
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace hapticlab::app
