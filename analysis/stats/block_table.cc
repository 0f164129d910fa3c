#include "analysis/stats/block_table.h"

#include <algorithm>
#include <map>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {

std::size_t BlockTable::treatment_index(const std::string& name) const {
  const auto it = std::find(treatment_names.begin(), treatment_names.end(), name);
  if (it != treatment_names.end()) return static_cast<std::size_t>(it - treatment_names.begin());
  std::string available;
  for (const auto& t : treatment_names) available += (available.empty() ? "" : ", ") + t;
  throw DataError("no treatment named '" + name + "'; the treatments are: " + available);
}

BlockTable BlockTable::from_observations(const std::vector<Observation>& observations) {
  BlockTable table;
  std::map<std::string, std::size_t> block_index;
  std::map<std::string, std::size_t> treatment_index;
  for (const auto& o : observations) {
    if (block_index.emplace(o.block, table.block_names.size()).second) {
      table.block_names.push_back(o.block);
    }
    if (treatment_index.emplace(o.treatment, table.treatment_names.size()).second) {
      table.treatment_names.push_back(o.treatment);
    }
  }
  table.cells.assign(table.block_names.size(),
                     std::vector<std::vector<double>>(table.treatment_names.size()));
  for (const auto& o : observations) {
    table.cells[block_index[o.block]][treatment_index[o.treatment]].push_back(o.value);
  }
  return table;
}

BlockTable BlockTable::from_matrix(const std::vector<std::vector<double>>& rows, std::size_t reps) {
  if (reps == 0) throw DataError("table of values: reps must be >= 1");
  if (rows.empty() || rows.size() % reps != 0) {
    throw DataError("table of values: " + std::to_string(rows.size()) +
                    " rows is not a positive multiple of reps = " + std::to_string(reps));
  }
  const std::size_t columns = rows.front().size();
  BlockTable table;
  const std::size_t blocks = rows.size() / reps;
  for (std::size_t b = 0; b < blocks; ++b) table.block_names.push_back(std::to_string(b + 1));
  for (std::size_t t = 0; t < columns; ++t) table.treatment_names.push_back(std::to_string(t + 1));
  table.cells.assign(blocks, std::vector<std::vector<double>>(columns));
  for (std::size_t r = 0; r < rows.size(); ++r) {
    if (rows[r].size() != columns) {
      throw DataError("table of values: row " + std::to_string(r + 1) + " has " +
                      std::to_string(rows[r].size()) + " values, row 1 has " +
                      std::to_string(columns));
    }
    for (std::size_t t = 0; t < columns; ++t) table.cells[r / reps][t].push_back(rows[r][t]);
  }
  return table;
}

BlockTable BlockTable::select_treatments(const std::vector<std::size_t>& treatment_indices) const {
  BlockTable out;
  out.block_names = block_names;
  for (std::size_t t : treatment_indices) out.treatment_names.push_back(treatment_names.at(t));
  out.cells.resize(cells.size());
  for (std::size_t b = 0; b < cells.size(); ++b) {
    for (std::size_t t : treatment_indices) out.cells[b].push_back(cells[b].at(t));
  }
  return out;
}

}  // namespace hapticlab::analysis
