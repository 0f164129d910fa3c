#include "core/common/csv_format.h"

#include <cstdint>
#include <cstdlib>
#include <limits>
#include <string>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

// RFC 4180: only a field with a comma, quote or line break is quoted, and a
// quote inside is doubled.
TEST(CsvFormatTest, QuotesOnlyWhereNeeded) {
  EXPECT_EQ(csv_text("High Fidelity"), "High Fidelity");
  EXPECT_EQ(csv_text("a,b"), "\"a,b\"");
  EXPECT_EQ(csv_text("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(csv_text("two\nlines"), "\"two\nlines\"");
  EXPECT_EQ(csv_text("cr\r"), "\"cr\r\"");
  EXPECT_EQ(csv_text(""), "");
  std::string line = "x,";
  append_csv_text(line, "y,z");
  EXPECT_EQ(line, "x,\"y,z\"");
}

// The shortest text that strtod reads back to the same double.
TEST(CsvFormatTest, NumbersAreShortestRoundTrip) {
  EXPECT_EQ(format_number(0.1), "0.1");
  EXPECT_EQ(format_number(0.1 + 0.2), "0.30000000000000004");
  EXPECT_EQ(format_number(2.5), "2.5");
  EXPECT_EQ(format_number(std::int64_t{-42}), "-42");
  EXPECT_EQ(format_number(std::uint64_t{18446744073709551615u}), "18446744073709551615");
  for (double v : {1.0 / 3.0, 2.0 / 3.0, 123456.78901234567, 1e-300 * 3.0,
                   std::numeric_limits<double>::max(), std::numeric_limits<double>::denorm_min(),
                   -0.0}) {
    const std::string text = format_number(v);
    EXPECT_EQ(std::strtod(text.c_str(), nullptr), v) << text;
  }
}

}  // namespace
}  // namespace hapticlab
