#include "core/device/trajectory_csv.h"

#include "core/common/input_file.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <istream>
#include <ostream>
#include <system_error>

#include "core/common/csv_format.h"

namespace hapticlab {
namespace {

// Positions in kTrajectoryInputColumns.
enum InputColumn : std::size_t {
  kColT, kColInstrument, kColInsertion, kColPitch, kColYaw, kColFx, kColFy, kColFz
};

constexpr std::size_t kUnset = static_cast<std::size_t>(-1);

std::string_view trim(std::string_view s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

void split_cells(std::string_view line, std::vector<std::string_view>& cells) {
  cells.clear();
  for (;;) {
    const std::size_t comma = line.find(',');
    cells.push_back(trim(line.substr(0, comma)));
    if (comma == std::string_view::npos) return;
    line.remove_prefix(comma + 1);
  }
}

// Empty string when `cell` is a number (stored in `value`), else what is wrong.
std::string parse_number(std::string_view cell, double& value) {
  if (cell.empty()) return "empty cell";
  std::string_view digits = cell;
  // from_chars rejects a leading '+', which spreadsheets sometimes write.
  if (digits.size() > 1 && digits.front() == '+' && digits[1] != '-') digits.remove_prefix(1);
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (ec == std::errc::result_out_of_range) {
    return "number out of the range of a double '" + std::string(cell) + "'";
  }
  if (ec != std::errc{} || end != digits.data() + digits.size()) {
    return "non-numeric cell '" + std::string(cell) + "'";
  }
  return {};
}

template <typename Names>
std::string join(const Names& names) {
  std::string s;
  for (const auto& n : names) {
    if (!s.empty()) s += ',';
    s += n;
  }
  return s;
}

std::string quoted_list(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "'" : ", '") + n + "'";
  return s;
}

}  // namespace

// ---------------------------------------------------------------- reader

TrajectoryCsvReader::TrajectoryCsvReader(std::istream& in, std::string source)
    : in_(&in), source_(std::move(source)) {
  read_header();
}

TrajectoryCsvReader::TrajectoryCsvReader(const std::filesystem::path& path)
    : owned_(std::make_unique<std::ifstream>(path, std::ios::binary)),
      in_(owned_.get()),
      source_(path.string()) {
  if (!*owned_) {
    throw TrajectoryCsvError(source_ + ": cannot open for reading: " + std::strerror(errno));
  }
  read_header();
}

TrajectoryCsvReader::~TrajectoryCsvReader() = default;
TrajectoryCsvReader::TrajectoryCsvReader(TrajectoryCsvReader&&) noexcept = default;
TrajectoryCsvReader& TrajectoryCsvReader::operator=(TrajectoryCsvReader&&) noexcept = default;

void TrajectoryCsvReader::fail(const std::string& what) const {
  throw TrajectoryCsvError(source_ + ": line " + std::to_string(line_number_) + ": " + what);
}

void TrajectoryCsvReader::fail(std::string_view column, const std::string& what) const {
  fail("column '" + std::string(column) + "': " + what);
}

bool TrajectoryCsvReader::read_line() {
  std::streambuf& in = *in_->rdbuf();
  using Traits = std::streambuf::traits_type;
  for (;;) {
    // One line, ended by LF, CRLF or a lone CR. Read through the stream
    // buffer rather than getline: getline knows one terminator, and it grows
    // the line without bound (a file of NUL bytes, /dev/zero).
    line_.clear();
    int c = in.sbumpc();
    if (Traits::eq_int_type(c, Traits::eof())) break;
    ++line_number_;
    while (!Traits::eq_int_type(c, Traits::eof()) && c != '\n' && c != '\r') {
      if (line_.size() >= kMaxCsvLineBytes) {
        fail("longer than the " + format_byte_limit(kMaxCsvLineBytes) +
             " limit for one line; is this a trajectory CSV file?");
      }
      line_ += Traits::to_char_type(c);
      c = in.sbumpc();
    }
    if (c == '\r' && in.sgetc() == '\n') in.sbumpc();
    // Spreadsheet exports often start with a UTF-8 byte order mark.
    if (line_number_ == 1 && line_.starts_with("\xEF\xBB\xBF")) line_.erase(0, 3);
    if (!trim(line_).empty()) return true;
  }
  if (in_->bad()) fail("read error");
  return false;
}

void TrajectoryCsvReader::read_header() {
  const std::string expected = " (expected the columns " + join(kTrajectoryInputColumns) + ")";
  if (!read_line()) {
    throw TrajectoryCsvError(source_ + ": empty file, no header line" + expected);
  }
  split_cells(line_, cells_);
  double first = 0.0;
  if (parse_number(cells_.front(), first).empty()) {
    fail("no header line, the first line holds numbers" + expected);
  }

  column_of_.fill(kUnset);
  std::vector<std::string> unknown;
  for (std::size_t i = 0; i < cells_.size(); ++i) {
    std::string_view name = cells_[i];
    if (name.size() >= 2 && name.front() == '"' && name.back() == '"') {
      name = name.substr(1, name.size() - 2);
    }
    for (std::size_t j = 0; j < column_names_.size(); ++j) {
      if (column_names_[j] == name) {
        fail("duplicate column '" + visible_text(name) + "' (fields " + std::to_string(j + 1) +
             " and " + std::to_string(i + 1) + ")");
      }
    }
    column_names_.emplace_back(name);
    bool known = false;
    for (std::size_t k = 0; k < kTrajectoryInputColumns.size(); ++k) {
      if (kTrajectoryInputColumns[k] == name) {
        column_of_[k] = i;
        known = true;
      }
    }
    for (std::string_view out : kTrajectoryOutputColumns) known = known || out == name;
    if (!known) unknown.push_back(visible_text(name));
  }
  if (!unknown.empty()) fail("unknown column(s) " + quoted_list(unknown) + expected);

  std::vector<std::string> missing;
  for (std::size_t k = 0; k < kTrajectoryInputColumns.size(); ++k) {
    if (column_of_[k] == kUnset) missing.emplace_back(kTrajectoryInputColumns[k]);
  }
  if (!missing.empty()) fail("missing column(s) " + quoted_list(missing) + expected);
}

bool TrajectoryCsvReader::next(TrajectoryRow& row) {
  if (!read_line()) return false;
  split_cells(line_, cells_);
  if (cells_.size() != column_names_.size()) {
    fail("expected " + std::to_string(column_names_.size()) + " fields (as in the header), got " +
         std::to_string(cells_.size()));
  }

  std::array<double, kTrajectoryInputColumns.size()> v{};
  for (std::size_t k = 0; k < v.size(); ++k) {
    const std::string problem = parse_number(cells_[column_of_[k]], v[k]);
    if (!problem.empty()) fail(kTrajectoryInputColumns[k], problem);
  }

  const std::string_view instrument_cell = cells_[column_of_[kColInstrument]];
  if (v[kColInstrument] != 0.0 && v[kColInstrument] != 1.0) {
    fail(kTrajectoryInputColumns[kColInstrument],
         "instrument must be 0 or 1, got '" + std::string(instrument_cell) + "'");
  }
  const int instrument = static_cast<int>(v[kColInstrument]);

  // t_s orders the rows and gives every dt, so it must be a real time.
  const double t_s = v[kColT];
  if (!std::isfinite(t_s)) {
    fail(kTrajectoryInputColumns[kColT],
         "time must be finite, got '" + std::string(cells_[column_of_[kColT]]) + "'");
  }
  if (seen_[instrument] && t_s < last_t_s_[instrument]) {
    fail(kTrajectoryInputColumns[kColT],
         "time goes backwards for instrument " + std::to_string(instrument) + ": " +
             format_number(t_s) + " s after " + format_number(last_t_s_[instrument]) + " s");
  }
  seen_[instrument] = true;
  last_t_s_[instrument] = t_s;

  row.t_s = t_s;
  row.instrument = instrument;
  row.position = JointVector(v[kColInsertion], v[kColPitch], v[kColYaw]);
  row.ve_force_N = Eigen::Vector3d(v[kColFx], v[kColFy], v[kColFz]);
  return true;
}

std::vector<TrajectoryRow> read_trajectory_csv(std::istream& in, const std::string& source) {
  TrajectoryCsvReader reader(in, source);
  std::vector<TrajectoryRow> rows;
  TrajectoryRow row;
  while (reader.next(row)) rows.push_back(row);
  return rows;
}

std::vector<TrajectoryRow> read_trajectory_csv(const std::filesystem::path& path) {
  TrajectoryCsvReader reader(path);
  std::vector<TrajectoryRow> rows;
  TrajectoryRow row;
  while (reader.next(row)) rows.push_back(row);
  return rows;
}

// ---------------------------------------------------------------- writer

TrajectoryCsvWriter::TrajectoryCsvWriter(std::ostream& out) : out_(out) {
  out_ << join(kTrajectoryInputColumns) << ',' << join(kTrajectoryOutputColumns) << '\n';
  if (!out_) throw TrajectoryCsvError("trajectory CSV: write failed");
}

void TrajectoryCsvWriter::write(const TrajectoryRow& row, const InstrumentOutput& result) {
  // Shortest text that reads back to the same double: files stay small and a
  // replayed output reproduces the numbers exactly.
  line_.clear();
  const auto add = [this](auto value) {
    if (!line_.empty()) line_ += ',';
    append_number(line_, value);
  };
  add(row.t_s);
  add(row.instrument);
  for (int a = 0; a < 3; ++a) add(row.position[a]);
  for (int a = 0; a < 3; ++a) add(row.ve_force_N[a]);
  for (int a = 0; a < 3; ++a) add(result.displayed_force_N[a]);
  for (int a = 0; a < 3; ++a) add(result.joint_force[a]);
  for (int a = 0; a < 3; ++a) add(result.degraded_position[a]);
  add(result.status);
  line_ += '\n';
  out_.write(line_.data(), static_cast<std::streamsize>(line_.size()));
  if (!out_) throw TrajectoryCsvError("trajectory CSV: write failed");
}

}  // namespace hapticlab
