#pragma once
// The child side of an isolated device plugin: the process that loads the
// plugin and serves the calls IsolatedPluginDevice sends through the
// PluginChannel (plugin_channel.h). `hapticlab device plugin-host` runs it;
// nobody else should.
//
// The plugin runs here exactly as in-process (PluginDevice: the same loader,
// the same checks); its clock callback returns the time the parent sent
// with the current call. A second thread passes halt requests to the
// plugin's halt() as they come, concurrently with the other calls.
//
// The host dies with its parent (PR_SET_PDEATHSIG: SIGKILL). A crash of the
// plugin ends it by the crash's own signal (the handlers a sanitizer or the
// command line installed are reset), so the parent can name it.

#include <sys/types.h>

namespace hapticlab {

// Serves the channel mapped from `channel_fd` until the parent sends
// kDestroy; then exits the process with status 0. Returns (with 2, after a
// message on stderr) only if it cannot start: `parent_pid` is not its
// parent any more, or the fd is not a channel of this build.
int run_plugin_host(int channel_fd, pid_t parent_pid);

}  // namespace hapticlab
