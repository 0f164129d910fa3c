#pragma once
#include <CLI/CLI.hpp>

namespace hapticlab::app {
// `hapticlab device keygen --out PATH`: a new key for the UDP bridge (32
// random bytes from the kernel, as hex) in a new file of mode 600, which
// the host (--device-option key_file=PATH) and the driver share.
void add_device_keygen_command(CLI::App& device);
}  // namespace hapticlab::app
