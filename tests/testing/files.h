#pragma once
// Reading what a command wrote.

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace hapticlab::testing {

// The whole file, byte for byte ("" if it cannot be read).
inline std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Whether `dir` holds a temporary output file, "<name>.<pid>.tmp"
// (core/common/output_file.h): left behind, it would mean a write was not
// finished or not cleaned up.
inline bool has_temp_file(const std::filesystem::path& dir) {
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".tmp") return true;
  return false;
}

}  // namespace hapticlab::testing
