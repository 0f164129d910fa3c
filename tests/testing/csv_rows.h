#pragma once
// A CSV file the commands wrote, as rows whose cells are looked up by the
// header's column names, for tests that check what a command wrote. Handles
// quoted cells (commas inside quotes); not a general CSV parser. The rows
// share one column index: a trial's sample export has tens of thousands of
// rows, and a map per row made one test take a minute under the sanitizers.

#include <cstddef>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

namespace hapticlab::testing {

class CsvRow {
 public:
  using Columns = std::unordered_map<std::string, std::size_t>;
  CsvRow(std::shared_ptr<const Columns> columns, std::vector<std::string> cells)
      : columns_(std::move(columns)), cells_(std::move(cells)) {}
  // The cell under `column`; std::out_of_range naming it when the header has
  // no such column or the row is too short to reach it.
  const std::string& at(const std::string& column) const {
    const auto it = columns_->find(column);
    if (it == columns_->end() || it->second >= cells_.size())
      throw std::out_of_range("CSV row has no cell in column '" + column + "'");
    return cells_[it->second];
  }

 private:
  std::shared_ptr<const Columns> columns_;
  std::vector<std::string> cells_;
};

inline std::vector<std::string> split_csv_line(std::string_view line) {
  std::vector<std::string> cells;
  std::string cell;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      cells.push_back(std::move(cell));
      cell.clear();
    } else {
      cell += c;
    }
  }
  cells.push_back(std::move(cell));
  return cells;
}

inline std::vector<CsvRow> read_csv_rows(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  std::vector<CsvRow> rows;
  if (!std::getline(in, line)) return rows;
  auto columns = std::make_shared<CsvRow::Columns>();
  const std::vector<std::string> header = split_csv_line(line);
  // Of two equal names, the later column's cells are found.
  for (std::size_t k = 0; k < header.size(); ++k) columns->insert_or_assign(header[k], k);
  while (std::getline(in, line)) rows.emplace_back(columns, split_csv_line(line));
  return rows;
}

}  // namespace hapticlab::testing
