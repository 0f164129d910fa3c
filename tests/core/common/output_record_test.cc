// An output folder holds one run's results: what an earlier run wrote and
// this one did not is removed, nothing the command did not write is.
#include "core/common/output_record.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/common/output_file.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;

class OutputRecordTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::path(::testing::TempDir()) / (std::string("output_record_test_") + info->name());
    fs::remove_all(root_);
    dir_ = root_ / "out";
    fs::create_directories(dir_ / "figures" / "learning_clip");
  }
  void TearDown() override { fs::remove_all(root_); }
  fs::path touch(const fs::path& p) const {
    std::ofstream(p) << "x";
    return p;
  }

  fs::path root_, dir_;
};

TEST_F(OutputRecordTest, TheFilesOfAnEarlierRunThisOneDidNotWriteAreRemoved) {
  const fs::path report = touch(dir_ / "report.html"), metrics = touch(dir_ / "metrics.csv");
  const fs::path curve = touch(dir_ / "figures" / "learning_clip" / "curve_1.svg");
  const fs::path notes = touch(dir_ / "notes.txt");  // the user's, never written by the command
  EXPECT_TRUE(replace_output_record(dir_, {report, metrics, curve}).empty());
  // The next run writes metrics.csv (and a figure of its own) only.
  const fs::path box = touch(dir_ / "figures" / "box.svg");
  const std::vector<fs::path> removed = replace_output_record(dir_, {metrics, box});
  EXPECT_THAT(removed, ::testing::UnorderedElementsAre(report, curve));
  EXPECT_FALSE(fs::exists(report));
  EXPECT_FALSE(fs::exists(dir_ / "figures" / "learning_clip")) << "the folder it left empty";
  EXPECT_TRUE(fs::exists(metrics));
  EXPECT_TRUE(fs::exists(box));
  EXPECT_TRUE(fs::exists(notes));
  std::ifstream in(dir_ / std::string(kOutputRecordName));
  std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_THAT(text, ::testing::EndsWith("\nfigures/box.svg\nmetrics.csv\n"));
}

// A record edited by hand (or made by something else) cannot reach outside
// the folder, nor through a link.
TEST_F(OutputRecordTest, ARecordNeverRemovesAFileOutsideTheFolderOrThroughALink) {
  const fs::path outside = touch(root_ / "outside.txt");
  const fs::path target = touch(root_ / "target.txt");
  fs::create_symlink(target, dir_ / "link.svg");
  std::ofstream(dir_ / std::string(kOutputRecordName))
      << "../outside.txt\n" << outside.string() << "\nfigures/../../outside.txt\nlink.svg\nfigures\n";
  EXPECT_TRUE(replace_output_record(dir_, {}).empty());
  EXPECT_TRUE(fs::exists(outside));
  EXPECT_TRUE(fs::exists(target));
  EXPECT_TRUE(fs::is_symlink(dir_ / "link.svg"));
  EXPECT_TRUE(fs::exists(dir_ / "figures"));
  EXPECT_THROW(replace_output_record(dir_, {outside}), OutputFileError);
}

}  // namespace
}  // namespace hapticlab
