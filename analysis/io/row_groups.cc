#include "analysis/io/row_groups.h"

#include <map>

namespace hapticlab::analysis {

std::vector<RowGroup> split_rows(const LongCsv& csv, const std::vector<std::string>& columns) {
  std::vector<std::size_t> indices;
  for (const auto& c : columns) indices.push_back(csv.column(c));
  std::vector<RowGroup> groups;
  std::map<std::vector<std::string>, std::size_t> index;
  for (std::size_t r = 0; r < csv.row_count(); ++r) {
    std::vector<std::string> values;
    for (std::size_t i : indices) values.push_back(csv.text(r, i));
    auto [it, inserted] = index.emplace(values, groups.size());
    if (inserted) {
      RowGroup g;
      for (std::size_t i = 0; i < columns.size(); ++i) {
        g.key.emplace_back(columns[i], values[i]);
        g.label += (i ? ", " : "") + columns[i] + "=" + values[i];
      }
      groups.push_back(std::move(g));
    }
    groups[it->second].rows.push_back(r);
  }
  return groups;
}

}  // namespace hapticlab::analysis
