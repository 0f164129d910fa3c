#include "app/device/device_keygen.h"

#include <cstdio>
#include <memory>
#include <string>

#include "core/common/secret_file.h"

namespace hapticlab::app {

void add_device_keygen_command(CLI::App& device) {
  auto out = std::make_shared<std::string>();
  CLI::App* cmd = device.add_subcommand(
      "keygen", "Make a key for the UDP bridge: 32 random bytes as hex in a new file of mode 600, for "
                "--device-option key_file=PATH on the host and the same file at the driver (docs/udp_bridge.md)");
  cmd->add_option("--out", *out, "The key file to create (an existing file is never replaced)")->required();
  cmd->callback([out] {
    create_secret_file(*out, random_hex(32));
    std::printf("wrote a new key to %s (mode 600); give the driver the same file, and HapticLab "
                "--device-option key_file=%s\n",
                out->c_str(), out->c_str());
  });
}

}  // namespace hapticlab::app
