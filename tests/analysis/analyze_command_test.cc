// `hapticlab analyze` in process: options reach the analysis, files land in
// --out, and bad input is an error naming it.
#include "app/study/analyze_command.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <gmock/gmock.h>
#include <nlohmann/json.hpp>
#include <gtest/gtest.h>

#include "analysis/io/long_csv.h"
#include "app/cli_process.h"
#include "study/synthetic_study_db.h"
#include "testing/sqlite_edit.h"

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
       "--ks-resamples", "100"});
  const auto csv = analysis::LongCsv::read(out + "/metrics.csv");
  EXPECT_EQ(csv.row_count(), 20u);
  // The energy of synthetic_study_db.h, worked by hand: the device gave
  // 9/128 J (left) and 9/256 J (right) on insertion, took nothing.
  for (std::size_t row = 0; row < csv.row_count(); ++row) {
    const double hand = csv.number(row, csv.column("instrument"));
    EXPECT_EQ(csv.number(row, csv.column("device_out_insertion_J")), hand == 0 ? 9.0 / 128 : 9.0 / 256) << row;
    for (const char* column : {"device_in_insertion_J", "device_out_pitch_J", "device_in_yaw_J"})
      EXPECT_EQ(csv.number(row, csv.column(column)), 0.0) << column << " row " << row;
  }
  EXPECT_TRUE(std::filesystem::exists(out + "/report.html"));
  EXPECT_TRUE(std::filesystem::exists(out + "/report.md"));
}

// Run again into the same --out, now without figures: the figures of the
// first run are removed (they would pass for this run's), a file of the
// user's in the folder is not, and stderr says what went.
TEST_F(AnalyzeCommandTest, ASecondRunIntoTheSameFolderLeavesNoFileOfTheFirstItDidNotWrite) {
  namespace fs = std::filesystem;
  const fs::path out = dir_.path() / "again";
  const std::string args = "analyze --db " + db_ + " --quiet --no-ks --out " + out.string();
  auto [status, text] = hapticlab::testing::run_cli(HAPTICLAB_CLI_PATH, args);
  ASSERT_EQ(status, 0) << text;
  std::size_t figures = 0;
  for (const auto& e : fs::directory_iterator(out / "figures")) figures += e.path().extension() == ".svg";
  ASSERT_GT(figures, 0u);
  std::ofstream(out / "notes.txt") << "the user's";
  std::tie(status, text) = hapticlab::testing::run_cli(HAPTICLAB_CLI_PATH, args + " --no-plots");
  ASSERT_EQ(status, 0) << text;
  EXPECT_THAT(text, HasSubstr("removed " + std::to_string(figures + 1) + " file(s) an earlier analyze wrote in " +
                              out.string() + " and this one did not"));  // the figures and plots.gp
  EXPECT_FALSE(fs::exists(out / "figures"));
  for (const char* kept : {"metrics.csv", "report.html", "report.md", "notes.txt"})
    EXPECT_TRUE(fs::exists(out / kept)) << kept;
}

TEST_F(AnalyzeCommandTest, JsonSummaryIsTheOnlyOutputAndAgreesWithTheCsv) {
  const std::string out = (dir_.path() / "out").string();
  ::testing::internal::CaptureStdout();
  run({"analyze", "--db", db_, "--out", out, "--no-plots", "--no-ks", "--json"});
  const std::string printed = ::testing::internal::GetCapturedStdout();
  const nlohmann::json j = nlohmann::json::parse(printed);  // nothing but the JSON on stdout
  const auto csv = analysis::LongCsv::read(out + "/metrics.csv");
  EXPECT_EQ(2 * j.at("trials").at("analysed").get<std::size_t>(), csv.row_count());  // a row per trial and hand
  EXPECT_EQ(j.at("files").at("metrics_csv"), out + "/metrics.csv");
  EXPECT_FALSE(j.at("whole_design").empty());
  EXPECT_GT(j.at("sidak_level").get<double>(), 0.0);
}

// A control without a single analysed trial (all aborted) gave a report of
// N/A comparisons with no reason: the reason is now a warning, in the JSON
// and the report.
TEST_F(AnalyzeCommandTest, AControlWithoutAnAnalysedTrialIsAWarning) {
  hapticlab::testing::edit_with_sqlite(db_, "UPDATE trial SET status = 'aborted', abort_reason = 'test' WHERE status <> "
                                            "'planned' AND setting_id = (SELECT id FROM setting WHERE name = "
                                            "'High Fidelity')");
  const std::string out = (dir_.path() / "out").string();
  ::testing::internal::CaptureStdout();
  run({"analyze", "--db", db_, "--out", out, "--no-plots", "--no-ks", "--json"});
  const nlohmann::json j = nlohmann::json::parse(::testing::internal::GetCapturedStdout());
  const std::string warnings = j.at("sessions").at("warnings").dump();
  EXPECT_THAT(warnings, HasSubstr("the control 'High Fidelity' has no analysed trial with measures"));
  std::ifstream report(out + "/report.md");
  std::stringstream text;
  text << report.rdbuf();
  EXPECT_THAT(text.str(), HasSubstr("so every comparison with it is N/A"));
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
        csv.text(r, csv.column("repetition")) == "1" && csv.text(r, csv.column("instrument")) == "0") {
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

// Through the real binary under a file size limit (prlimit, util-linux: in
// bytes, unlike sh's ulimit -f), which fails the writes
// part-way as a full disk does (EFBIG instead of ENOSPC): every output is
// complete or absent, and the message names the file and the cause. The
// limit must leave room for SQLite's 32 KiB shared-memory file (the database
// is in WAL mode) and be smaller than report.html with its inline figures.
TEST_F(AnalyzeCommandTest, FullDiskLeavesNoPartialOutput) {
  namespace fs = std::filesystem;
  const std::string args = "analyze --db " + db_ + " --quiet --ks-resamples 100 --out ";
  const fs::path full = dir_.path() / "full";
  const auto [full_status, full_text] = hapticlab::testing::run_cli(HAPTICLAB_CLI_PATH, args + full.string());
  ASSERT_EQ(full_status, 0) << full_text;
  constexpr std::uintmax_t kLimit_bytes = 48 * 1024;
  ASSERT_GT(fs::file_size(full / "report.html"), kLimit_bytes) << "the test needs a report larger than the limit";

  const fs::path out = dir_.path() / "out";
  const auto [status, text] =
      hapticlab::testing::run_cli("prlimit --fsize=" + std::to_string(kLimit_bytes) + " " + HAPTICLAB_CLI_PATH,
                                  args + out.string());
  EXPECT_EQ(status, 1) << text;
  EXPECT_THAT(text, HasSubstr((out / "report.html").string() + ": cannot write: File too large"));
  EXPECT_FALSE(fs::exists(out / "report.html"));
  // What was written before the failure is complete: byte for byte the same
  // as in the unlimited run; nothing else (no temporary file) is left.
  for (const auto& e : fs::recursive_directory_iterator(out)) {
    if (e.is_directory()) continue;
    const fs::path twin = full / fs::relative(e.path(), out);
    ASSERT_TRUE(fs::exists(twin)) << e.path() << " was left behind";
    std::ifstream a(e.path(), std::ios::binary), b(twin, std::ios::binary);
    std::stringstream sa, sb;
    sa << a.rdbuf();
    sb << b.rdbuf();
    EXPECT_TRUE(sa.str() == sb.str()) << e.path() << " differs from the unlimited run";
  }
}

}  // namespace
}  // namespace hapticlab::app
