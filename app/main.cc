// hapticlab: command line entry point.
#include <csignal>
#include <cstdio>

#include <CLI/CLI.hpp>

#include "app/bench_engine.h"
#include "app/engine_demo.h"
#include "app/study_demo.h"
#include "app/engine_replay.h"
#include "app/settings_check.h"
#include "app/sim_replay.h"
#include "app/sim_run.h"
#include "app/stats_command.h"
#include "app/analyze_command.h"
#include "app/bench_analyze.h"
#include "app/study_command.h"
#include "app/session_command.h"
#include "app/console_command.h"
#include "app/bench_loop.h"
#include "app/export_command.h"
#include "app/bench_db.h"
#include "app/device_command.h"
#include "app/bench_device.h"
#include "app/device_serve_sim.h"
#include "app/bench_udp.h"
#include "app/cli_errors.h"
#include "app/plan_command.h"
#include "app/stability_command.h"
#include "core/common/build_info.h"

int main(int argc, char** argv) {
  // A file size limit (ulimit -f) should fail the write with EFBIG, which the
  // output files report with the path, instead of killing the process with
  // SIGXFSZ and leaving a temporary file behind.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"HapticLab: make a high-end haptic device feel like inexpensive hardware, "
               "and study whether it matters.",
               "hapticlab"};
  app.require_subcommand(1);
  app.set_version_flag("--version", hapticlab::software_version());

  hapticlab::app::add_study_demo_command(app);

  CLI::App* engine = app.add_subcommand("engine", "Run the degradation engine offline");
  engine->require_subcommand(1);
  hapticlab::app::add_engine_replay_command(*engine);
  hapticlab::app::add_engine_demo_command(*engine);

  CLI::App* settings = app.add_subcommand("settings", "Work with settings files");
  settings->require_subcommand(1);
  hapticlab::app::add_settings_check_command(*settings);

  CLI::App* sim = app.add_subcommand("sim", "Simulated rig: participant, workstation and tasks");
  sim->require_subcommand(1);
  hapticlab::app::add_sim_run_command(*sim);
  hapticlab::app::add_sim_replay_command(*sim);

  hapticlab::app::add_study_command(app);
  hapticlab::app::add_session_command(app);
  hapticlab::app::add_console_command(app);
  hapticlab::app::add_stats_command(app);
  hapticlab::app::add_analyze_command(app);
  hapticlab::app::add_export_command(app);
  hapticlab::app::add_plan_command(app);
  hapticlab::app::add_stability_command(app);
  CLI::App* device = app.add_subcommand("device", "Work with haptic devices: check one, serve the simulated one");
  device->require_subcommand(1);
  hapticlab::app::add_device_check_command(*device);
  hapticlab::app::add_device_serve_sim_command(*device);

  CLI::App* bench = app.add_subcommand("bench", "Measure performance");
  bench->require_subcommand(1);
  hapticlab::app::add_bench_engine_command(*bench);
  hapticlab::app::add_bench_loop_commands(*bench);
  hapticlab::app::add_bench_analyze_command(*bench);
  hapticlab::app::add_bench_db_command(*bench);
  hapticlab::app::add_bench_device_command(*bench);
  hapticlab::app::add_bench_udp_command(*bench);

  hapticlab::app::add_help_command(app);
  app.footer(hapticlab::app::exit_status_help());
  return hapticlab::app::run_command_line(app, argc, argv);
}
