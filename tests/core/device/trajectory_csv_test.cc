#include "core/device/trajectory_csv.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/input_file.h"

namespace hapticlab {
namespace {

const std::string kHeader =
    "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N\n";

std::vector<TrajectoryRow> parse(const std::string& text) {
  std::istringstream in(text);
  return read_trajectory_csv(in, "test.csv");
}

// The error message parse() throws, or "" if it does not throw.
std::string parse_error(const std::string& text) {
  try {
    parse(text);
  } catch (const TrajectoryCsvError& e) {
    return e.what();
  }
  return "";
}

::testing::AssertionResult contains(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "'" << text << "' does not contain '" << part << "'";
}

TEST(TrajectoryCsv, ReadsColumnsInAnyOrder) {
  const auto rows = parse(
      "ve_force_z_N,yaw_rad,instrument,t_s,ve_force_x_N,insertion_m,ve_force_y_N,pitch_rad\n"
      "6,3,1,0.5,4,0.1,5,2\n"
      "-6,-3,0,0.25,-4,0.2,-5,-2\n");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].t_s, 0.5);
  EXPECT_EQ(rows[0].instrument, 1);
  EXPECT_EQ(rows[0].position, JointVector(0.1, 2, 3));
  EXPECT_EQ(rows[0].ve_force_N, Eigen::Vector3d(4, 5, 6));
  // Instruments have separate clocks: 0.25 after 0.5 is fine for another instrument.
  EXPECT_EQ(rows[1].t_s, 0.25);
  EXPECT_EQ(rows[1].instrument, 0);
  EXPECT_EQ(rows[1].position, JointVector(0.2, -2, -3));
}

TEST(TrajectoryCsv, AcceptsCrlfBlankLinesAndTrailingNewline) {
  const auto rows = parse(
      "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N\r\n"
      "0,0,0.1,0,0,0,0,0\r\n"
      "\r\n"
      "\n"
      "0.001,0,0.1,0,0,0,0,1.5\r\n");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].ve_force_N.z(), 1.5);
}

// Old Mac and some spreadsheet exports end lines with a lone CR; the line
// numbers still count every line, in any mix of endings.
TEST(TrajectoryCsv, AcceptsCrOnlyAndMixedLineEndings) {
  std::istringstream in(
      "\xEF\xBB\xBFt_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N\r"
      "0,0,0.1,0,0,0,0,0\r"
      "0.001,0,0.1,0,0,0,0,1.5\n"
      "0.002,0,0.1,0,0,0,0,2.5\r\n"
      "0.003,0,0.1,0,0,0,0,3.5");
  TrajectoryCsvReader reader(in, "cr.csv");
  TrajectoryRow row;
  std::vector<std::pair<std::size_t, double>> seen;
  while (reader.next(row)) seen.emplace_back(reader.line_number(), row.ve_force_N.z());
  const std::vector<std::pair<std::size_t, double>> expected = {{2, 0.0}, {3, 1.5}, {4, 2.5}, {5, 3.5}};
  EXPECT_EQ(seen, expected);
}

TEST(TrajectoryCsvErrors, InvisibleCharactersInColumnNamesAreShown) {
  // A byte order mark after the first line is not stripped; it is named.
  const std::string message =
      parse_error("t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,\xEF\xBB\xBFve_force_z_N\n");
  EXPECT_TRUE(contains(message, "unknown column(s) '<U+FEFF>ve_force_z_N'"));
}

// A file without line breaks (here: a megabyte of zero bytes) is refused at
// the line limit instead of being read into memory whole.
TEST(TrajectoryCsvErrors, OverlongLineIsRefused) {
  const std::string message = parse_error(kHeader + std::string(kMaxCsvLineBytes + 10, '\0'));
  EXPECT_TRUE(contains(message, "test.csv: line 2: longer than the 1 MiB limit for one line"));
}

TEST(TrajectoryCsv, AcceptsNonFiniteJointsAndForces) {
  const auto rows = parse(kHeader + "0,0,nan,0,0,inf,-inf,NaN\n");
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_TRUE(std::isnan(rows[0].position[0]));
  EXPECT_EQ(rows[0].ve_force_N.x(), std::numeric_limits<double>::infinity());
  EXPECT_EQ(rows[0].ve_force_N.y(), -std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(rows[0].ve_force_N.z()));
}

TEST(TrajectoryCsv, EqualTimesAreAllowed) {
  EXPECT_EQ(parse(kHeader + "1,0,0,0,0,0,0,0\n1,0,0,0,0,0,0,0\n").size(), 2u);
}

TEST(TrajectoryCsv, StreamingReaderReportsLineNumbers) {
  std::istringstream in(kHeader + "\n0,0,0,0,0,0,0,0\n0.1,1,0,0,0,0,0,0\n");
  TrajectoryCsvReader reader(in);
  TrajectoryRow row;
  ASSERT_TRUE(reader.next(row));
  EXPECT_EQ(reader.line_number(), 3u);
  ASSERT_TRUE(reader.next(row));
  EXPECT_EQ(reader.line_number(), 4u);
  EXPECT_EQ(row.instrument, 1);
  EXPECT_FALSE(reader.next(row));
  EXPECT_EQ(row.instrument, 1);  // unchanged at the end
}

TEST(TrajectoryCsv, OutputColumnsAreIgnoredSoOutputsCanBeReplayed) {
  std::ostringstream out;
  TrajectoryCsvWriter writer(out);
  TrajectoryRow row;
  row.position = JointVector(0.1, 0.2, 0.3);
  writer.write(row, InstrumentOutput{});
  const auto rows = parse(out.str());
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].position, row.position);
}

TEST(TrajectoryCsvErrors, EmptyFile) {
  EXPECT_TRUE(contains(parse_error(""), "test.csv: empty file"));
  EXPECT_TRUE(contains(parse_error("\r\n\n"), "empty file"));
}

TEST(TrajectoryCsvErrors, MissingHeader) {
  const std::string msg = parse_error("0,0,0,0,0,0,0,0\n");
  EXPECT_TRUE(contains(msg, "test.csv: line 1: no header line"));
  EXPECT_TRUE(contains(msg, "t_s,instrument,insertion_m"));
}

TEST(TrajectoryCsvErrors, MissingColumnsAreListed) {
  const std::string msg = parse_error("t_s,instrument,insertion_m,pitch_rad,ve_force_x_N\n");
  EXPECT_TRUE(contains(msg, "line 1: missing column(s) 'yaw_rad', 've_force_y_N', 've_force_z_N'"));
}

TEST(TrajectoryCsvErrors, DuplicateColumn) {
  const std::string msg = parse_error(
      "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N,"
      "pitch_rad\n");
  EXPECT_TRUE(contains(msg, "line 1: duplicate column 'pitch_rad' (fields 4 and 9)"));
}

TEST(TrajectoryCsvErrors, UnknownColumn) {
  const std::string msg = parse_error(
      "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N,"
      "ve_force_w_N\n");
  EXPECT_TRUE(contains(msg, "line 1: unknown column(s) 've_force_w_N'"));
}

TEST(TrajectoryCsvErrors, WrongFieldCount) {
  const std::string msg = parse_error(kHeader + "0,0,0,0,0,0,0,0\n0.1,0,0,0,0,0,0\n");
  EXPECT_TRUE(contains(msg, "test.csv: line 3: expected 8 fields"));
  EXPECT_TRUE(contains(msg, "got 7"));
}

TEST(TrajectoryCsvErrors, NonNumericCell) {
  const std::string msg = parse_error(kHeader + "0,0,0,0,0,0,0,0\n\n0.1,0,0,abc,0,0,0,0\n");
  EXPECT_TRUE(contains(msg, "test.csv: line 4: column 'pitch_rad': non-numeric cell 'abc'"));
  EXPECT_TRUE(contains(parse_error(kHeader + "0,0,0,0,0,0,,0\n"),
                       "line 2: column 've_force_y_N': empty cell"));
  EXPECT_TRUE(contains(parse_error(kHeader + "0,0,0,0,0,0,1.5x,0\n"), "non-numeric cell '1.5x'"));
}

TEST(TrajectoryCsvErrors, InstrumentNotZeroOrOne) {
  EXPECT_TRUE(contains(parse_error(kHeader + "0,2,0,0,0,0,0,0\n"),
                       "line 2: column 'instrument': instrument must be 0 or 1, got '2'"));
  EXPECT_TRUE(contains(parse_error(kHeader + "0,0.5,0,0,0,0,0,0\n"), "got '0.5'"));
}

TEST(TrajectoryCsvErrors, TimeGoingBackwardsForTheSameInstrument) {
  const std::string msg =
      parse_error(kHeader + "1,0,0,0,0,0,0,0\n0.5,1,0,0,0,0,0,0\n0.9,0,0,0,0,0,0,0\n");
  EXPECT_TRUE(contains(msg, "line 4: column 't_s': time goes backwards for instrument 0"));
  EXPECT_TRUE(contains(msg, "0.9 s after 1 s"));
}

TEST(TrajectoryCsvErrors, NonFiniteTime) {
  EXPECT_TRUE(contains(parse_error(kHeader + "nan,0,0,0,0,0,0,0\n"),
                       "line 2: column 't_s': time must be finite"));
}

TEST(TrajectoryCsvErrors, FileNameInMessages) {
  const std::filesystem::path path =
      std::filesystem::path(::testing::TempDir()) / "trajectory_csv_test_bad.csv";
  std::ofstream(path) << kHeader << "0,0,0,0,0,0,0,x\n";
  try {
    read_trajectory_csv(path);
    FAIL() << "no exception";
  } catch (const TrajectoryCsvError& e) {
    EXPECT_TRUE(contains(e.what(), path.string() + ": line 2: column 've_force_z_N'"));
  }
  std::filesystem::remove(path);
  EXPECT_THROW(read_trajectory_csv(path), TrajectoryCsvError);  // cannot open
}

TEST(TrajectoryCsvWriter, HeaderHasEveryColumnInTheDocumentedOrder) {
  std::ostringstream out;
  TrajectoryCsvWriter writer(out);
  EXPECT_EQ(out.str(),
            "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N,"
            "displayed_force_x_N,displayed_force_y_N,displayed_force_z_N,insertion_force_N,"
            "pitch_torque_Nm,yaw_torque_Nm,degraded_insertion_m,degraded_pitch_rad,"
            "degraded_yaw_rad,fault\n");
}

TEST(TrajectoryCsvWriter, RoundTripsDoublesExactly) {
  TrajectoryRow row;
  row.t_s = 1.0 / 3.0;
  row.instrument = 1;
  row.position = JointVector(0.1 + 1e-17, -std::numbers::pi / 7, 5e-324);
  row.ve_force_N = Eigen::Vector3d(1e300, -0.0, std::numeric_limits<double>::quiet_NaN());
  InstrumentOutput result;
  result.displayed_force_N = Eigen::Vector3d(std::nextafter(1.0, 2.0), -2.5e-8, 3.0);
  result.joint_force = JointVector(0.45, -0.03, 1.0 / 7.0);
  result.degraded_position = JointVector(0.123456789012345678, 0.2, -0.3);
  result.status = 0x25;

  std::ostringstream out;
  TrajectoryCsvWriter writer(out);
  writer.write(row, result);

  // Parse every cell back with strtod, independent of the reader.
  std::istringstream in(out.str());
  std::string header, line;
  std::getline(in, header);
  std::getline(in, line);
  std::vector<double> v;
  std::istringstream cells(line);
  for (std::string cell; std::getline(cells, cell, ',');) {
    v.push_back(std::strtod(cell.c_str(), nullptr));
  }
  ASSERT_EQ(v.size(), kTrajectoryInputColumns.size() + kTrajectoryOutputColumns.size());

  const double expected[] = {row.t_s, 1, row.position[0], row.position[1], row.position[2],
                             row.ve_force_N[0], row.ve_force_N[1], row.ve_force_N[2],
                             result.displayed_force_N[0], result.displayed_force_N[1],
                             result.displayed_force_N[2], result.joint_force[0],
                             result.joint_force[1], result.joint_force[2],
                             result.degraded_position[0], result.degraded_position[1],
                             result.degraded_position[2], 0x25};
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (std::isnan(expected[i])) {
      EXPECT_TRUE(std::isnan(v[i])) << "column " << i;
    } else {
      EXPECT_EQ(v[i], expected[i]) << "column " << i;
      EXPECT_EQ(std::signbit(v[i]), std::signbit(expected[i])) << "column " << i;
    }
  }

  // And the reader gets the input part back bit for bit.
  const auto rows = parse(out.str());
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].t_s, row.t_s);
  EXPECT_EQ(rows[0].position, row.position);
  EXPECT_EQ(rows[0].ve_force_N.head<2>(), row.ve_force_N.head<2>());
  EXPECT_TRUE(std::isnan(rows[0].ve_force_N.z()));
}

}  // namespace
}  // namespace hapticlab
