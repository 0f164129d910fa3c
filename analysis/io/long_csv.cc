#include "analysis/io/long_csv.h"

#include <charconv>
#include <cmath>
#include <set>

#include "analysis/stats/data_error.h"
#include "core/common/input_file.h"

namespace hapticlab::analysis {
namespace {

std::string trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t");
  return std::string(s.substr(first, last - first + 1));
}

// Splits one line into fields; quoted fields keep commas and "" escapes.
std::vector<std::string> split_fields(std::string_view line, const std::string& where) {
  std::vector<std::string> fields;
  std::string field;
  bool quoted = false;
  bool was_quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"' && trim(field).empty()) {
      quoted = true;
      was_quoted = true;
      field.clear();
    } else if (c == ',') {
      fields.push_back(was_quoted ? field : trim(field));
      field.clear();
      was_quoted = false;
    } else {
      field += c;
    }
  }
  if (quoted) throw DataError(where + ": unterminated quoted field");
  fields.push_back(was_quoted ? field : trim(field));
  return fields;
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  // Invisible characters shown, so "participant" and "<U+FEFF>participant"
  // do not look the same in a message.
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + visible_text(n);
  return out;
}

}  // namespace

LongCsv LongCsv::read(const std::filesystem::path& path) {
  try {
    return parse(read_text_file(path, kMaxCsvFileBytes, "CSV file"), path.string());
  } catch (const InputFileError& e) {
    throw DataError(e.what());
  }
}

LongCsv LongCsv::without_empty(const std::vector<std::string>& columns, std::size_t& dropped) const {
  std::vector<std::size_t> indices;
  for (const std::string& c : columns) indices.push_back(column(c));
  LongCsv kept;
  kept.source_ = source_;
  kept.columns_ = columns_;
  dropped = 0;
  for (std::size_t r = 0; r < rows_.size(); ++r) {
    bool empty = false;
    for (std::size_t i : indices) empty = empty || rows_[r][i].empty();
    if (empty) {
      ++dropped;
      continue;
    }
    kept.rows_.push_back(rows_[r]);
    kept.lines_.push_back(lines_[r]);
  }
  return kept;
}

LongCsv LongCsv::parse(std::string_view text, std::string source) {
  LongCsv csv;
  csv.source_ = std::move(source);
  // Spreadsheet exports often start with a UTF-8 byte order mark.
  if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);
  std::size_t line_number = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    // A line ends at LF, CRLF or a lone CR (old Mac and some Excel exports).
    auto end = text.find_first_of("\r\n", pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(pos, end - pos);
    pos = end + (text.substr(end).starts_with("\r\n") ? 2 : 1);
    ++line_number;
    if (trim(line).empty()) continue;
    const std::string where = csv.source_ + ":" + std::to_string(line_number);
    auto fields = split_fields(line, where);
    if (csv.columns_.empty()) {
      std::set<std::string> seen;
      for (std::size_t c = 0; c < fields.size(); ++c) {
        if (fields[c].empty()) {
          throw DataError(where + ": header column " + std::to_string(c + 1) + " has no name");
        }
        if (!seen.insert(fields[c]).second) {
          throw DataError(where + ": header names column '" + visible_text(fields[c]) + "' twice");
        }
      }
      csv.columns_ = std::move(fields);
    } else {
      if (fields.size() != csv.columns_.size()) {
        throw DataError(where + ": " + std::to_string(fields.size()) + " fields, but the header has " +
                        std::to_string(csv.columns_.size()) + " columns (" + join(csv.columns_) + ")");
      }
      csv.rows_.push_back(std::move(fields));
      csv.lines_.push_back(line_number);
    }
  }
  if (csv.columns_.empty()) throw DataError(csv.source_ + ": empty file; expected a header row");
  return csv;
}

std::size_t LongCsv::column(const std::string& name) const {
  for (std::size_t c = 0; c < columns_.size(); ++c) {
    if (columns_[c] == name) return c;
  }
  throw DataError(source_ + ": no column named '" + visible_text(name) + "'; the columns are: " + join(columns_));
}

double LongCsv::number(std::size_t row, std::size_t column) const {
  const std::string& field = text(row, column);
  double value = 0.0;
  const char* first = field.data();
  const char* last = field.data() + field.size();
  if (!field.empty() && *first == '+') ++first;  // from_chars refuses a leading '+'
  const auto [ptr, ec] = std::from_chars(first, last, value);
  if (field.empty() || ec != std::errc() || ptr != last || !std::isfinite(value)) {
    throw DataError(source_ + ":" + std::to_string(line(row)) + ": column '" + columns_[column] +
                    "': '" + visible_text(field) + "' is not a finite number");
  }
  return value;
}

std::vector<Observation> read_observations(const LongCsv& csv, const LongColumns& columns,
                                           std::size_t min_blocks, std::size_t min_treatments) {
  // No block column: every row is one block (a pooled two-sample test).
  const bool has_block = !columns.block.empty();
  const std::size_t block = has_block ? csv.column(columns.block) : 0;
  const std::size_t treatment = csv.column(columns.treatment);
  const std::size_t value = csv.column(columns.value);
  const bool has_replicate = !columns.replicate.empty();
  const std::size_t replicate = has_replicate ? csv.column(columns.replicate) : 0;

  std::vector<Observation> out;
  out.reserve(csv.row_count());
  std::set<std::string> blocks;
  std::set<std::string> treatments;
  for (std::size_t r = 0; r < csv.row_count(); ++r) {
    Observation o;
    o.block = has_block ? csv.text(r, block) : "";
    o.treatment = csv.text(r, treatment);
    for (const auto& [name, index] : {std::pair{&columns.block, block},
                                      std::pair{&columns.treatment, treatment}}) {
      if (name == &columns.block && !has_block) continue;
      if (csv.text(r, index).empty()) {
        throw DataError(csv.source() + ":" + std::to_string(csv.line(r)) + ": column '" + *name +
                        "' is empty");
      }
    }
    if (has_replicate) o.replicate = csv.text(r, replicate);
    o.value = csv.number(r, value);
    blocks.insert(o.block);
    treatments.insert(o.treatment);
    out.push_back(std::move(o));
  }
  if (blocks.size() < min_blocks) {
    throw DataError(csv.source() + ": column '" + columns.block + "' has " +
                    std::to_string(blocks.size()) + " distinct block(s) (" +
                    join({blocks.begin(), blocks.end()}) + "); at least " +
                    std::to_string(min_blocks) + " are needed");
  }
  if (treatments.size() < min_treatments) {
    throw DataError(csv.source() + ": column '" + columns.treatment + "' has " +
                    std::to_string(treatments.size()) + " distinct treatment(s) (" +
                    join({treatments.begin(), treatments.end()}) + "); at least " +
                    std::to_string(min_treatments) + " are needed");
  }
  return out;
}

}  // namespace hapticlab::analysis
