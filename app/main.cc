// hapticlab: command line entry point.
#include <cstdio>
#include <exception>

#include <CLI/CLI.hpp>

#include "app/bench_engine.h"
#include "app/engine_demo.h"
#include "app/engine_replay.h"
#include "app/settings_check.h"
#include "app/sim_run.h"
#include "app/stats_command.h"
#include "app/bench_loop.h"

int main(int argc, char** argv) {
  CLI::App app{"HapticLab: make a high-end haptic device feel like inexpensive hardware, "
               "and study whether it matters."};
  app.require_subcommand(1);
  app.set_version_flag("--version", HAPTICLAB_VERSION_STRING);

  hapticlab::app::add_demo_command(app);

  CLI::App* engine = app.add_subcommand("engine", "Run the degradation engine offline");
  engine->require_subcommand(1);
  hapticlab::app::add_engine_replay_command(*engine);

  CLI::App* settings = app.add_subcommand("settings", "Work with settings files");
  settings->require_subcommand(1);
  hapticlab::app::add_settings_check_command(*settings);

  CLI::App* sim = app.add_subcommand("sim", "Simulated rig: participant, workstation and tasks");
  sim->require_subcommand(1);
  hapticlab::app::add_sim_run_command(*sim);

  hapticlab::app::add_stats_command(app);

  CLI::App* bench = app.add_subcommand("bench", "Measure performance");
  bench->require_subcommand(1);
  hapticlab::app::add_bench_engine_command(*bench);
  hapticlab::app::add_bench_loop_commands(*bench);

  if (argc == 1) {
    std::fputs(app.help().c_str(), stdout);
    return 0;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hapticlab: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
