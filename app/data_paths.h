#pragma once
// Where the shipped example files are: the source tree when run from a
// build, the installed data directory otherwise.
#include <filesystem>

namespace hapticlab::app {
std::filesystem::path default_settings_dir();
std::filesystem::path default_protocols_dir();
}  // namespace hapticlab::app
