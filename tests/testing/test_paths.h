#pragma once
// What the tests start as real processes or load, built by this tree
// (tests/CMakeLists.txt defines the paths for every test executable).

#include <string>

namespace hapticlab {

inline const std::string kBinary = HAPTICLAB_CLI_PATH;  // the `hapticlab` command
inline const std::string kSimPlugin = HAPTICLAB_SIM_PLUGIN_PATH;  // hapticlab_sim_device.so
inline const std::string kFake = HAPTICLAB_FAKE_PLUGIN_PATH;  // tests/core/device/fake_device_plugin.c

}  // namespace hapticlab
