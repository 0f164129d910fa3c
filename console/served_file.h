#pragma once
// Which file a download URL may name: one inside a folder the console
// writes (the analysis, the exports, the tuning page's files), never outside.

#include <filesystem>
#include <optional>
#include <string>

namespace hapticlab::console {

// The plain file `name` names inside `root` ("report.html",
// "figures/x.svg"), or nothing: each '/'-separated part must be letters,
// digits, '_', '-' and '.', not start with '.', and the file must be a
// regular file whose real path (links followed) stays inside `root`.
std::optional<std::filesystem::path> served_file(const std::filesystem::path& root, const std::string& name);

}  // namespace hapticlab::console
