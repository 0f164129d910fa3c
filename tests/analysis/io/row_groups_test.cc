#include "analysis/io/row_groups.h"

#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

const char* kCsv =
    "participant,task,value\n"
    "S2,clip,1\n"
    "S1,clip,2\n"
    "S2,dissection,3\n"
    "S2,clip,4\n"
    "S1,clip,5\n";

TEST(RowGroupsTest, GroupsInOrderOfFirstAppearanceWithTheirRowsInFileOrder) {
  const LongCsv csv = LongCsv::parse(kCsv, "t.csv");
  const auto groups = split_rows(csv, {"participant", "task"});
  ASSERT_EQ(groups.size(), 3u);
  EXPECT_EQ(groups[0].label, "participant=S2, task=clip");
  EXPECT_EQ(groups[0].rows, (std::vector<std::size_t>{0, 3}));
  EXPECT_EQ(groups[1].label, "participant=S1, task=clip");
  EXPECT_EQ(groups[1].rows, (std::vector<std::size_t>{1, 4}));
  EXPECT_EQ(groups[2].rows, (std::vector<std::size_t>{2}));
  ASSERT_EQ(groups[2].key.size(), 2u);
  EXPECT_EQ(groups[2].key[0], (std::pair<std::string, std::string>{"participant", "S2"}));
  EXPECT_EQ(groups[2].key[1], (std::pair<std::string, std::string>{"task", "dissection"}));
}

TEST(RowGroupsTest, NoColumnsIsOneGroupOfEveryRowAndAMissingColumnIsNamed) {
  const LongCsv csv = LongCsv::parse(kCsv, "t.csv");
  const auto all = split_rows(csv, {});
  ASSERT_EQ(all.size(), 1u);
  EXPECT_EQ(all[0].rows.size(), 5u);
  EXPECT_TRUE(all[0].label.empty());
  try {
    split_rows(csv, {"site"});
    FAIL() << "a missing column was accepted";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("site"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hapticlab::analysis
