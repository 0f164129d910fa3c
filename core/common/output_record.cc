#include "core/common/output_record.h"

#include <algorithm>
#include <fstream>
#include <set>
#include <string>
#include <system_error>

#include "core/common/output_file.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;

// A record's line as a path that stays inside the folder, or empty.
fs::path inside(const std::string& line) {
  const fs::path p = fs::path(line).lexically_normal();
  if (line.empty() || p.is_absolute() || p.empty() || *p.begin() == "..") return {};
  return p;
}

std::set<fs::path> read_record(const fs::path& record) {
  std::set<fs::path> listed;
  std::ifstream in(record);
  for (std::string line; std::getline(in, line);) {
    if (line.starts_with('#')) continue;
    if (fs::path p = inside(line); !p.empty()) listed.insert(p);
  }
  return listed;
}

}  // namespace

std::vector<fs::path> replace_output_record(const fs::path& dir, const std::vector<fs::path>& written) {
  const fs::path base = fs::absolute(dir).lexically_normal();
  std::set<fs::path> now;
  for (const fs::path& w : written) {
    const fs::path rel = fs::absolute(w).lexically_normal().lexically_relative(base);
    if (inside(rel.string()).empty())
      throw OutputFileError(w.string() + ": not inside the output folder " + dir.string() + " (a bug)");
    now.insert(rel.lexically_normal());
  }
  const fs::path record = dir / kOutputRecordName;
  std::vector<fs::path> removed;
  for (const fs::path& old : read_record(record)) {
    if (now.contains(old)) continue;
    const fs::path file = dir / old;
    std::error_code ec;
    if (!fs::is_regular_file(fs::symlink_status(file, ec)) || !fs::remove(file, ec)) continue;
    removed.push_back(file);
    // The folders it leaves empty (figures/learning_clip), up to `dir`.
    for (fs::path parent = old.parent_path(); !parent.empty(); parent = parent.parent_path())
      if (!fs::is_empty(dir / parent, ec) || ec || !fs::remove(dir / parent, ec)) break;
  }
  std::string text = "# The files the last run wrote here (relative to this folder); the next run into this folder\n"
                     "# removes those it does not write again. Delete this file to keep them.\n";
  for (const fs::path& p : now) text += p.generic_string() + '\n';
  write_file_atomically(record, text);
  return removed;
}

}  // namespace hapticlab
