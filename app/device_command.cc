#include "app/device_command.h"

namespace hapticlab::app {

CLI::App& device_group(CLI::App& app) {
  for (CLI::App* sub : app.get_subcommands([](CLI::App* a) { return a->get_name() == "device"; })) return *sub;
  CLI::App* device = app.add_subcommand("device", "Work with haptic devices: serve the simulated one, check one");
  device->require_subcommand(1);
  return *device;
}

}  // namespace hapticlab::app
