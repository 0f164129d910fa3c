#include "app/cli/data_paths.h"

#include <unistd.h>

#include <array>
#include <cstdlib>
#include <optional>
#include <system_error>
#include <vector>

namespace hapticlab::app {

namespace fs = std::filesystem;

namespace {

// The running executable's directory, from /proc (Linux): an installed copy
// finds its data relative to itself, wherever the prefix was moved.
std::optional<fs::path> executable_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec || exe.empty()) return std::nullopt;
  return exe.parent_path();
}

// Candidates, first match wins:
//   $HAPTICLAB_DATA_DIR/<sub>          the user's own override
//   <exe>/../share/hapticlab/<sub>     an installed copy, relocatable
//   <source tree>/examples/<sub>       a build tree (the binary in build/app)
fs::path find_data_dir(const char* sub, const char* marker_file) {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("HAPTICLAB_DATA_DIR"); env != nullptr && *env != '\0')
    candidates.push_back(fs::path(env) / sub);
  if (const auto dir = executable_dir()) candidates.push_back(*dir / ".." / "share" / "hapticlab" / sub);
  candidates.push_back(fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / sub);
  std::error_code ec;
  for (const fs::path& c : candidates)
    if (fs::exists(c / marker_file, ec)) return fs::weakly_canonical(c, ec);
  return fs::path("examples") / sub;
}

}  // namespace

fs::path default_settings_dir() { return find_data_dir("settings", "high_fidelity.json"); }

fs::path default_protocols_dir() { return find_data_dir("protocols", "thesis_as_run.json"); }

fs::path default_population_file() { return find_data_dir("population", "fitted.json") / "fitted.json"; }

}  // namespace hapticlab::app
