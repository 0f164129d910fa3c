#pragma once
// A CSV file the commands wrote, as rows keyed by the header's column names,
// for tests that check what a command wrote. Handles quoted cells (commas
// inside quotes); not a general CSV parser.

#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace hapticlab::testing {

inline std::vector<std::map<std::string, std::string>> read_csv_rows(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> header;
  std::vector<std::map<std::string, std::string>> rows;
  auto split = [](const std::string& l) {
    std::vector<std::string> cells;
    std::string cell;
    bool quoted = false;
    for (char c : l) {
      if (c == '"') quoted = !quoted;
      else if (c == ',' && !quoted) {
        cells.push_back(cell);
        cell.clear();
      } else {
        cell += c;
      }
    }
    cells.push_back(cell);
    return cells;
  };
  if (!std::getline(in, line)) return rows;
  header = split(line);
  while (std::getline(in, line)) {
    const auto cells = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t k = 0; k < header.size() && k < cells.size(); ++k) row[header[k]] = cells[k];
    rows.push_back(row);
  }
  return rows;
}

}  // namespace hapticlab::testing
