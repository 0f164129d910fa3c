#pragma once
// Long-format CSV for the statistics: a header row of column names, then one
// observation per row, e.g.
//
//   participant,hand,setting,repetition,force_95p_N
//   S1,right,HiFi,1,2.31
//
// Fields are separated by commas; a field may be double-quoted ("a,b", with
// "" for a quote). Blank lines are skipped; lines may end in LF, CRLF or a
// lone CR; a UTF-8 byte order mark before the header is ignored. A file
// larger than kMaxCsvFileBytes (core/common/input_file.h) is refused. Messages
// show invisible characters in names and values (<U+FEFF>, \r, \t).
// Every error is a DataError naming the file and, where it applies, the
// line, the column and the offending value.
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/stats/block_table.h"

namespace hapticlab::analysis {

class LongCsv {
 public:
  // Throws DataError if the file cannot be read, has no header, a duplicate
  // or empty column name, or a row whose field count differs from the header.
  static LongCsv read(const std::filesystem::path& path);
  // The same from text; `source` names it in messages (e.g. a file name).
  static LongCsv parse(std::string_view text, std::string source);

  const std::string& source() const { return source_; }
  const std::vector<std::string>& columns() const { return columns_; }
  std::size_t row_count() const { return rows_.size(); }
  // Index of a column; throws DataError naming the missing column and listing
  // the available ones.
  std::size_t column(const std::string& name) const;
  // 1-based line number of a data row in the file.
  std::size_t line(std::size_t row) const { return lines_.at(row); }
  const std::string& text(std::size_t row, std::size_t column) const {
    return rows_.at(row).at(column);
  }
  // The field as a finite number; throws DataError naming file, line, column
  // and value otherwise (empty, non-numeric, trailing text, NaN, Inf).
  double number(std::size_t row, std::size_t column) const;

  // A copy without the rows whose field is empty in any of `columns` (a
  // measure the analysis could not compute is an empty cell in metrics.csv);
  // `dropped` counts them. Throws DataError for a missing column.
  LongCsv without_empty(const std::vector<std::string>& columns, std::size_t& dropped) const;

 private:
  std::string source_;
  std::vector<std::string> columns_;
  std::vector<std::vector<std::string>> rows_;
  std::vector<std::size_t> lines_;
};

// Column names of a block design. An empty `replicate` means no replicate
// column: several rows of one block and treatment are then replicates in file
// order. An empty `block` means no block column: all rows form one block.
struct LongColumns {
  std::string block = "block";
  std::string treatment = "treatment";
  std::string replicate;
  std::string value = "value";
};

// Every row as an Observation. Throws DataError for a missing column or a bad
// value, and when there are fewer than `min_blocks` distinct blocks or fewer
// than `min_treatments` distinct treatments (message names the column and
// the values found).
std::vector<Observation> read_observations(const LongCsv& csv, const LongColumns& columns,
                                           std::size_t min_blocks = 2,
                                           std::size_t min_treatments = 2);

}  // namespace hapticlab::analysis
