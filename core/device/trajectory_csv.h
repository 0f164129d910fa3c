#pragma once
// Trajectory CSV files: what the instruments did (input) and what the engine
// answered (output), one row per engine update.
//
// Input columns, in any order, header row required:
//   t_s, instrument, insertion_m, pitch_rad, yaw_rad,
//   ve_force_x_N, ve_force_y_N, ve_force_z_N
// `instrument` is 0 (left) or 1 (right). Rows of the two instruments may
// interleave; t_s must not decrease between two rows of the same instrument
// (equal times are allowed and mean dt = 0). Joints and forces use the
// conventions of core/engine/joint_transform.h: world frame z up out of the
// patient, tool along −z at zero angles, VE force on the tip in the world
// frame; positive insertion force pushes toward larger insertion.
//
// The output file (TrajectoryCsvWriter) has the input columns in the order
// above followed by kTrajectoryOutputColumns. Those output columns are
// accepted and ignored when reading, so an output file can be replayed
// again; any other column is an error, so a typo in a column name is never
// silently read as a default.
//
// Cells: numbers as std::from_chars reads them (a leading '+' and spaces
// around the cell are allowed). "nan" and "inf" (any case, optionally signed)
// are accepted in the joint and force columns on purpose: the engine turns a
// non-finite input into zero force plus kFaultNonFiniteInput, and replaying
// such a recording is how that path is tested. t_s must be finite, since it
// orders the rows and every dt is computed from it.
//
// Lines may end in LF, CRLF or a lone CR; empty lines are skipped; a UTF-8
// byte order mark before the header is ignored. A line longer than
// kMaxCsvLineBytes (core/common/input_file.h) is refused, so a file of any length
// is read in bounded memory. Every error is a TrajectoryCsvError whose
// message names the source, the line and, where one is at fault, the column;
// invisible characters in column names are shown (<U+FEFF>, \r, \t).

#include <array>
#include <cstddef>
#include <filesystem>
#include <iosfwd>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "core/engine/instrument.h"
#include "core/engine/joint_transform.h"
#include "core/settings/settings.h"

namespace hapticlab {

class TrajectoryCsvError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr std::array<std::string_view, 8> kTrajectoryInputColumns = {
    "t_s",     "instrument",   "insertion_m",  "pitch_rad",
    "yaw_rad", "ve_force_x_N", "ve_force_y_N", "ve_force_z_N"};

// `fault` is InstrumentOutput::status, the StatusFlag bits (core/engine/status.h).
inline constexpr std::array<std::string_view, 10> kTrajectoryOutputColumns = {
    "displayed_force_x_N", "displayed_force_y_N", "displayed_force_z_N",
    "insertion_force_N",   "pitch_torque_Nm",     "yaw_torque_Nm",
    "degraded_insertion_m", "degraded_pitch_rad", "degraded_yaw_rad",
    "fault"};

struct TrajectoryRow {
  double t_s = 0.0;
  int instrument = 0;                                     // 0 or 1
  JointVector position = JointVector::Zero();             // insertion m, pitch rad, yaw rad
  Eigen::Vector3d ve_force_N = Eigen::Vector3d::Zero();  // VE force on the tip, world frame
};

// Reads rows one at a time, so a recording of any length needs constant
// memory. The header is read and checked by the constructor.
class TrajectoryCsvReader {
 public:
  // `in` must outlive the reader; `source` names it in error messages.
  explicit TrajectoryCsvReader(std::istream& in, std::string source = "<stream>");
  // Opens and owns the file; the path is the source in error messages.
  explicit TrajectoryCsvReader(const std::filesystem::path& path);
  ~TrajectoryCsvReader();
  TrajectoryCsvReader(TrajectoryCsvReader&&) noexcept;
  TrajectoryCsvReader& operator=(TrajectoryCsvReader&&) noexcept;

  // Reads the next row into `row`; false at the end of the input (then `row`
  // is unchanged). Throws TrajectoryCsvError on a malformed line.
  bool next(TrajectoryRow& row);

  // Line of the row last returned (the header is line 1 unless preceded by
  // empty lines).
  std::size_t line_number() const noexcept { return line_number_; }
  const std::string& source() const noexcept { return source_; }

 private:
  void read_header();
  [[noreturn]] void fail(const std::string& what) const;
  [[noreturn]] void fail(std::string_view column, const std::string& what) const;
  bool read_line();

  std::unique_ptr<std::istream> owned_;  // set when the reader opened the file
  std::istream* in_;
  std::string source_;
  std::size_t line_number_ = 0;
  std::string line_;
  std::vector<std::string_view> cells_;
  std::vector<std::string> column_names_;  // as in the header, for messages
  // Header position of each input column, in kTrajectoryInputColumns order.
  std::array<std::size_t, kTrajectoryInputColumns.size()> column_of_{};
  std::array<double, kNumInstruments> last_t_s_{};
  std::array<bool, kNumInstruments> seen_{};
};

// Whole file in memory: for tests and short recordings.
std::vector<TrajectoryRow> read_trajectory_csv(const std::filesystem::path& path);
std::vector<TrajectoryRow> read_trajectory_csv(std::istream& in,
                                               const std::string& source = "<stream>");

// Writes the header in the constructor, then one line per write(). Numbers
// are written in the shortest form that reads back to the same double.
class TrajectoryCsvWriter {
 public:
  // `out` must outlive the writer.
  explicit TrajectoryCsvWriter(std::ostream& out);

  // Throws TrajectoryCsvError if the stream fails (e.g. disk full).
  void write(const TrajectoryRow& row, const InstrumentOutput& result);

 private:
  std::ostream& out_;
  std::string line_;
};

}  // namespace hapticlab
