#pragma once
// A long CSV's rows split by the values of some columns (the `--group`
// option of `hapticlab stats`): one group per distinct combination, each
// test run on its own group.
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "analysis/io/long_csv.h"

namespace hapticlab::analysis {

struct RowGroup {
  std::vector<std::pair<std::string, std::string>> key;  // (column, value), in the columns' order
  std::string label;                                     // "participant=S1, task=clip"
  std::vector<std::size_t> rows;                         // data rows, in file order
};

// The groups in order of first appearance. No columns: one group of every
// row (label and key empty). Throws DataError naming a missing column.
std::vector<RowGroup> split_rows(const LongCsv& csv, const std::vector<std::string>& columns);

}  // namespace hapticlab::analysis
