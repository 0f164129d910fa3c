#include "app/data_paths.h"

namespace hapticlab::app {

namespace fs = std::filesystem;

fs::path default_settings_dir() {
  for (const fs::path& candidate : {fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings",
                                   fs::path(HAPTICLAB_DATA_DIR) / "settings"}) {
    if (fs::exists(candidate / "high_fidelity.json")) return candidate;
  }
  return fs::path("examples") / "settings";
}

fs::path default_protocols_dir() {
  for (const fs::path& candidate : {fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "protocols",
                                   fs::path(HAPTICLAB_DATA_DIR) / "protocols"}) {
    if (fs::exists(candidate / "thesis_as_run.json")) return candidate;
  }
  return fs::path("examples") / "protocols";
}

}  // namespace hapticlab::app
