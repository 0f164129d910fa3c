#include "app/device/device_plugin_host.h"

#include <memory>

#include "core/device/isolated_plugin_device.h"
#include "core/device/plugin_host.h"

namespace hapticlab::app {

void add_device_plugin_host_command(CLI::App& device) {
  struct Opts {
    int channel_fd = -1;
    int parent_pid = 0;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = device.add_subcommand("plugin-host", "The process an isolated device plugin runs in (internal)");
  cmd->group("");  // not listed: HapticLab starts it
  cmd->add_option("--channel-fd", o->channel_fd, "The channel's file descriptor")->required();
  cmd->add_option("--parent-pid", o->parent_pid, "The process that started this one")->required();
  cmd->callback([o] {
    // Returns only if it cannot start; otherwise the process ends in there.
    throw CLI::RuntimeError(run_plugin_host(o->channel_fd, static_cast<pid_t>(o->parent_pid)));
  });
}

// The running image itself, even if the file was replaced since: the host
// must be of the same build (the channel's layout).
void register_plugin_host() { set_plugin_host_executable("/proc/self/exe"); }

}  // namespace hapticlab::app
