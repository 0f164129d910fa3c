#pragma once
// A two-way layout for block designs: blocks (participants, or participant ×
// hand) by treatments (hardware settings), each cell holding zero or more
// observations. An empty cell is a missing cell; several observations in a
// cell are replicates (repetitions of the task).
#include <cstddef>
#include <string>
#include <vector>

namespace hapticlab::analysis {

// One row of long-format data. `replicate` is empty when the data has no
// replicate column; observations of one cell keep their input order.
struct Observation {
  std::string block;
  std::string treatment;
  std::string replicate;
  double value = 0.0;
};

struct BlockTable {
  std::vector<std::string> block_names;      // in order of first appearance
  std::vector<std::string> treatment_names;  // in order of first appearance
  // cells[b][t]: the observations of block b under treatment t (empty: missing)
  std::vector<std::vector<std::vector<double>>> cells;

  std::size_t block_count() const { return block_names.size(); }
  std::size_t treatment_count() const { return treatment_names.size(); }
  // Index of a treatment by name; throws DataError listing the treatments.
  std::size_t treatment_index(const std::string& name) const;

  // Groups observations by block and treatment names.
  static BlockTable from_observations(const std::vector<Observation>& observations);

  // MATLAB layout, as in `friedman(x, reps)`: columns are treatments, and each
  // block is `reps` consecutive rows. rows.size() must be a multiple of reps
  // and every row as long as the first. Blocks are named "1", "2", ... and
  // treatments "1", "2", ... . Throws DataError otherwise.
  static BlockTable from_matrix(const std::vector<std::vector<double>>& rows, std::size_t reps = 1);

  // The same table restricted to the given treatment indices, in that order.
  BlockTable select_treatments(const std::vector<std::size_t>& treatment_indices) const;
};

}  // namespace hapticlab::analysis
