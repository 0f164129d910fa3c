// The `hapticlab` command tree: every subcommand registered on one CLI::App.
// Kept in the library, not in main.cc, so that CLI11 (header-only) is
// compiled once, in the library's unity batch, instead of again for the
// executable (app/CMakeLists.txt).
#include "app/cli/command_line.h"

#include <csignal>

#include <CLI/CLI.hpp>

#include "app/bench/bench_engine.h"
#include "app/engine/engine_demo.h"
#include "app/study/study_demo.h"
#include "app/engine/engine_replay.h"
#include "app/engine/settings_check.h"
#include "app/engine/sim_replay.h"
#include "app/engine/sim_run.h"
#include "app/study/stats_command.h"
#include "app/study/analyze_command.h"
#include "app/bench/bench_analyze.h"
#include "app/study/study_command.h"
#include "app/study/session_command.h"
#include "app/study/console_command.h"
#include "app/bench/bench_loop.h"
#include "app/study/export_command.h"
#include "app/bench/bench_db.h"
#include "app/device/device_command.h"
#include "app/device/device_plugin_host.h"
#include "app/bench/bench_device.h"
#include "app/device/device_keygen.h"
#include "app/device/device_serve_sim.h"
#include "app/bench/bench_udp.h"
#include "app/cli/cli_errors.h"
#include "app/plan/plan_command.h"
#include "app/plan/stability_command.h"
#include "core/common/build_info.h"

namespace hapticlab::app {
namespace {

// A command that only groups others (`hapticlab bench ...`): one of them
// must be named.
CLI::App& command_group(CLI::App& parent, const char* name, const char* description) {
  CLI::App* group = parent.add_subcommand(name, description);
  group->require_subcommand(1);
  return *group;
}

}  // namespace

int hapticlab_main(int argc, char** argv) {
  // A file size limit (ulimit -f) should fail the write with EFBIG, which the
  // output files report with the path, instead of killing the process with
  // SIGXFSZ and leaving a temporary file behind.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"HapticLab: make a high-end haptic device feel like inexpensive hardware, "
               "and study whether it matters.",
               "hapticlab"};
  app.require_subcommand(1);
  app.set_version_flag("--version", software_version());

  add_study_demo_command(app);

  CLI::App& engine = command_group(app, "engine", "Run the degradation engine offline");
  add_engine_replay_command(engine);
  add_engine_demo_command(engine);

  CLI::App& settings = command_group(app, "settings", "Work with settings files");
  add_settings_check_command(settings);

  CLI::App& sim = command_group(app, "sim", "Simulated rig: participant, workstation and tasks");
  add_sim_run_command(sim);
  add_sim_replay_command(sim);

  add_study_command(app);
  add_session_command(app);
  add_console_command(app);
  add_stats_command(app);
  add_analyze_command(app);
  add_export_command(app);
  add_plan_command(app);
  add_stability_command(app);
  CLI::App& device = command_group(app, "device", "Work with haptic devices: check one, serve the simulated one, make a bridge key");
  add_device_check_command(device);
  add_device_serve_sim_command(device);
  add_device_keygen_command(device);
  add_device_plugin_host_command(device);
  register_plugin_host();

  CLI::App& bench = command_group(app, "bench", "Measure performance");
  add_bench_engine_command(bench);
  add_bench_loop_commands(bench);
  add_bench_analyze_command(bench);
  add_bench_db_command(bench);
  add_bench_device_command(bench);
  add_bench_udp_command(bench);

  add_help_command(app);
  app.footer(exit_status_help());
  return run_command_line(app, argc, argv);
}

}  // namespace hapticlab::app
