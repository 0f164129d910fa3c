#include "analysis/io/long_csv.h"

#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// The error message of `f()`, which must throw DataError.
template <typename F>
std::string error_of(F f) {
  try {
    f();
  } catch (const DataError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected DataError";
  return {};
}

const char* const kGood =
    "participant,setting,rep,force_N\r\n"
    "S1,HiFi,1,1.5\r\n"
    "\r\n"
    "S1,\"No FFB, off\",1,2.5e0\r\n"
    "S2,HiFi,1,+1.25\r\n"
    "S2,\"No FFB, off\",1, 3 \r\n";

LongColumns columns() { return {"participant", "setting", "rep", "force_N"}; }

TEST(LongCsvTest, ReadsObservations) {
  const LongCsv csv = LongCsv::parse(kGood, "good.csv");
  EXPECT_EQ(csv.row_count(), 4u);
  EXPECT_EQ(csv.line(1), 4u);  // the blank line 3 is skipped but counted
  const auto obs = read_observations(csv, columns());
  ASSERT_EQ(obs.size(), 4u);
  EXPECT_EQ(obs[1].treatment, "No FFB, off");
  EXPECT_EQ(obs[1].value, 2.5);
  EXPECT_EQ(obs[2].value, 1.25);
  EXPECT_EQ(obs[3].value, 3.0);
  EXPECT_EQ(obs[3].replicate, "1");
}

TEST(LongCsvTest, MissingColumnListsTheAvailableOnes) {
  const LongCsv csv = LongCsv::parse(kGood, "good.csv");
  const std::string what = error_of([&] {
    read_observations(csv, {"surgeon", "setting", "", "force_N"});
  });
  EXPECT_THAT(what, HasSubstr("good.csv"));
  EXPECT_THAT(what, HasSubstr("'surgeon'"));
  EXPECT_THAT(what, HasSubstr("participant, setting, rep, force_N"));
}

TEST(LongCsvTest, NonNumericValueNamesFileLineColumnAndValue) {
  const LongCsv csv = LongCsv::parse(
      "participant,setting,rep,force_N\nS1,HiFi,1,1.5\nS2,HiFi,1,1.2N\n", "study.csv");
  const std::string what = error_of([&] { read_observations(csv, columns()); });
  EXPECT_THAT(what, HasSubstr("study.csv:3"));
  EXPECT_THAT(what, HasSubstr("'force_N'"));
  EXPECT_THAT(what, HasSubstr("'1.2N'"));
}

TEST(LongCsvTest, EmptyAndNonFiniteValuesAreRejected) {
  for (const char* bad : {"", "nan", "inf", "1e999"}) {
    const LongCsv csv = LongCsv::parse(
        std::string("participant,setting,rep,force_N\nS1,HiFi,1,") + bad + "\n", "x.csv");
    EXPECT_THROW(csv.number(0, 3), DataError) << "value '" << bad << "'";
  }
}

TEST(LongCsvTest, TooFewBlocks) {
  const LongCsv csv = LongCsv::parse(
      "participant,setting,rep,force_N\nS1,HiFi,1,1\nS1,NoFFB,1,2\n", "one.csv");
  const std::string what = error_of([&] { read_observations(csv, columns()); });
  EXPECT_THAT(what, HasSubstr("one.csv"));
  EXPECT_THAT(what, HasSubstr("'participant'"));
  EXPECT_THAT(what, HasSubstr("1 distinct block(s) (S1)"));
}

TEST(LongCsvTest, TooFewTreatments) {
  const LongCsv csv = LongCsv::parse(
      "participant,setting,rep,force_N\nS1,HiFi,1,1\nS2,HiFi,1,2\n", "one.csv");
  const std::string what = error_of([&] { read_observations(csv, columns()); });
  EXPECT_THAT(what, HasSubstr("'setting'"));
  EXPECT_THAT(what, HasSubstr("1 distinct treatment(s) (HiFi)"));
}

TEST(LongCsvTest, WrongFieldCountNamesTheLine) {
  const std::string what = error_of([] {
    LongCsv::parse("a,b,c\n1,2,3\n1,2\n", "short.csv");
  });
  EXPECT_THAT(what, HasSubstr("short.csv:3"));
  EXPECT_THAT(what, HasSubstr("2 fields"));
}

TEST(LongCsvTest, EmptyBlockNameIsRejected) {
  const LongCsv csv = LongCsv::parse(
      "participant,setting,rep,force_N\n,HiFi,1,1\nS2,NoFFB,1,2\n", "e.csv");
  const std::string what = error_of([&] { read_observations(csv, columns()); });
  EXPECT_THAT(what, HasSubstr("e.csv:2"));
  EXPECT_THAT(what, HasSubstr("'participant' is empty"));
}

TEST(LongCsvTest, HeaderProblems) {
  EXPECT_THAT(error_of([] { LongCsv::parse("", "empty.csv"); }), HasSubstr("empty.csv"));
  EXPECT_THAT(error_of([] { LongCsv::parse("a,a\n", "dup.csv"); }), HasSubstr("'a' twice"));
  EXPECT_THAT(error_of([] { LongCsv::parse("a,\"b\n", "q.csv"); }), HasSubstr("unterminated"));
}

TEST(LongCsvTest, ReadsAFileAndNamesAMissingOne) {
  const auto dir = std::filesystem::path(::testing::TempDir());
  const auto path = dir / "long_csv_test_input.csv";
  std::ofstream(path) << kGood;
  EXPECT_EQ(LongCsv::read(path).row_count(), 4u);
  std::filesystem::remove(path);
  EXPECT_THAT(error_of([&] { LongCsv::read(dir / "no_such_file.csv"); }),
              HasSubstr("no_such_file.csv"));
}

// A spreadsheet's UTF-8 byte order mark is not part of the first column's name.
TEST(LongCsvTest, ByteOrderMarkIsStripped) {
  const LongCsv csv = LongCsv::parse("\xEF\xBB\xBFparticipant,x\nS1,1\n", "bom.csv");
  EXPECT_EQ(csv.column("participant"), 0u);
}

TEST(LongCsvTest, CrOnlyAndMixedLineEndingsAreLines) {
  const LongCsv csv = LongCsv::parse("a,b\r1,2\n3,4\r\n\r5,6", "cr.csv");
  ASSERT_EQ(csv.row_count(), 3u);
  EXPECT_EQ(csv.text(2, 1), "6");
  EXPECT_EQ(csv.line(0), 2u);
  EXPECT_EQ(csv.line(2), 5u);  // the blank line 4 counts
}

TEST(LongCsvTest, InvisibleCharactersAreNamedInMessages) {
  const LongCsv csv = LongCsv::parse("\xE2\x80\x8Bparticipant,x\xC2\xA0\nS1,1\n", "hidden.csv");
  EXPECT_THAT(error_of([&] { csv.column("participant"); }),
              HasSubstr("the columns are: <U+200B>participant, x<U+00A0>"));
}

}  // namespace
}  // namespace hapticlab::analysis
