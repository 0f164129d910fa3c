// `hapticlab analyze` in process: options reach the analysis, files land in
// --out, and bad input is an error naming it.
#include "app/analyze_command.h"

#include <fstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/io/long_csv.h"
#include "study/synthetic_study_db.h"

namespace hapticlab::app {
namespace {

using ::testing::HasSubstr;

void run(std::vector<std::string> args) {
  CLI::App app;
  add_analyze_command(app);
  args.insert(args.begin(), "hapticlab");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  app.parse(static_cast<int>(argv.size()), argv.data());
}

class AnalyzeCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    db_ = (dir_.path() / "study.db").string();
    analysis::testing::build_synthetic_study(db_);
  }
  analysis::testing::ScratchDir dir_;
  std::string db_;
};

TEST_F(AnalyzeCommandTest, WritesCsvAndReport) {
  const std::string out = (dir_.path() / "out").string();
  run({"analyze", "--db", db_, "--out", out, "--no-plots", "--quiet", "--ks-stride", "1", "--ks-block", "2",
       "--ks-resamples", "50"});
  const auto csv = analysis::LongCsv::read(out + "/metrics.csv");
  EXPECT_EQ(csv.row_count(), 20u);
  EXPECT_TRUE(std::filesystem::exists(out + "/report.html"));
  EXPECT_TRUE(std::filesystem::exists(out + "/report.md"));
}

TEST_F(AnalyzeCommandTest, IncludeAbortedAndPercentileMethodReachTheAnalysis) {
  const std::string out = (dir_.path() / "out").string();
  run({"analyze", "--db", db_, "--out", out, "--no-plots", "--quiet", "--no-ks", "--include-aborted",
       "--percentile-method", "r7"});
  const auto csv = analysis::LongCsv::read(out + "/metrics.csv");
  EXPECT_EQ(csv.row_count(), 22u);
  // R type 7 puts the 95th percentile of {f..5f} at 1 + 4·0.95 = 4.8 -> 4.8 f
  // (MATLAB would give 5 f).
  const double f = analysis::testing::trial_force_N(1, 0, 1);
  bool seen = false;
  for (std::size_t r = 0; r < csv.row_count(); ++r) {
    if (csv.text(r, csv.column("participant")) == "P1" && csv.text(r, csv.column("setting")) == "High Fidelity" &&
        csv.text(r, csv.column("repetition")) == "1" && csv.text(r, csv.column("hand")) == "left") {
      seen = true;
      EXPECT_NEAR(csv.number(r, csv.column("force_p95_N")), 4.8 * f, 1e-6);
    }
  }
  EXPECT_TRUE(seen);
}

TEST_F(AnalyzeCommandTest, BadInputIsAnError) {
  const std::string out = (dir_.path() / "out").string();
  EXPECT_THAT([&] { run({"analyze", "--db", (dir_.path() / "nope.db").string(), "--out", out, "--no-plots"}); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("nope.db")));
  EXPECT_THAT([&] { run({"analyze", "--db", db_, "--out", out, "--no-plots", "--percentile-method", "bogus"}); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("bogus")));
  EXPECT_THAT([&] { run({"analyze", "--db", db_, "--out", out, "--no-plots", "--ks-block", "0"}); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("ks_block_length is 0")));
  EXPECT_THROW(run({"analyze", "--out", out}), CLI::RequiredError);
}

}  // namespace
}  // namespace hapticlab::app
