#include "console/served_file.h"

#include <cctype>
#include <system_error>

namespace hapticlab::console {

std::optional<std::filesystem::path> served_file(const std::filesystem::path& root, const std::string& name) {
  if (name.empty() || name.size() > 255) return std::nullopt;
  std::size_t part_start = 0;
  for (std::size_t i = 0; i <= name.size(); ++i) {
    if (i == name.size() || name[i] == '/') {
      // An empty part ("a//b", "/abs", "dir/") or a hidden one (".", "..", ".x").
      if (i == part_start || name[part_start] == '.') return std::nullopt;
      part_start = i + 1;
      continue;
    }
    const char c = name[i];
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.') return std::nullopt;
  }
  std::error_code ec;
  const std::filesystem::path real_root = std::filesystem::weakly_canonical(root, ec);
  if (ec) return std::nullopt;
  const std::filesystem::path p = std::filesystem::weakly_canonical(root / name, ec);
  if (ec || !std::filesystem::is_regular_file(p)) return std::nullopt;
  const auto rel = p.lexically_relative(real_root);
  if (rel.empty() || *rel.begin() == "..") return std::nullopt;  // a link that leads out
  return p;
}

}  // namespace hapticlab::console
