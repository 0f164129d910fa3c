#pragma once
// Where the shipped settings and protocols are: $HAPTICLAB_DATA_DIR if set,
// else <prefix>/share/hapticlab beside an installed binary (found from the
// binary's own path, so a moved prefix still works), else the source tree
// when run from a build directory.
#include <filesystem>

namespace hapticlab::app {
std::filesystem::path default_settings_dir();
std::filesystem::path default_protocols_dir();
// The shipped fitted population (examples/population/fitted.json).
std::filesystem::path default_population_file();
}  // namespace hapticlab::app
