// `hapticlab stats learning` and `hapticlab stats transfer` through the real
// binary: what they print, write and refuse.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/app/cli_process.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

TEST(StatsLearningProcess, LearningTransferAndRefusals) {
  const fs::path dir = fs::path(::testing::TempDir()) / "stats_learning_process";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path csv = dir / "trials.csv";
  {
    std::ofstream out(csv);
    out.precision(17);
    out << "participant,group,phase,trial,completion_time_s\n";
    for (int p = 1; p <= 6; ++p) {
      const std::string id = "P" + std::to_string(p), group = p <= 3 ? "hifi" : "lofi";
      out << id << ',' << group << ",pre,1," << 60 + p << '\n';
      for (int n = 1; n <= 12; ++n) out << id << ',' << group << ",training," << n << ',' << 20 + 40 * std::pow(n, -0.8) << '\n';
      out << id << ',' << group << ",post,1," << (p <= 3 ? 30 + p : 25 + p) << '\n';
    }
  }
  const std::string cli = HAPTICLAB_CLI_PATH;
  const fs::path out_dir = dir / "out";
  auto [rc, text] = testing::run_cli(cli, "stats learning " + csv.string() + " --measure completion_time_s --cusum-criterion 30 "
                                              "--p0 0.1 --p1 0.3 --alpha 0.05 --beta 0.2 --out " + out_dir.string());
  EXPECT_EQ(rc, 0) << text;
  EXPECT_THAT(text, HasSubstr("P1 (hifi, 12 trials): power, plateau 20 (SE 0)"));
  EXPECT_THAT(text, HasSubstr("CUSUM (s 0.1862, h1 2.054, h0 1.154)"));
  for (const char* f : {"curves.csv", "cusum.csv", "curve_1.svg", "cusum_6.svg", "group_medians.svg"})
    EXPECT_TRUE(fs::exists(out_dir / f)) << f;

  // A full disk (a file size limit fails the write part-way as one does):
  // curves.csv complete or absent, the file and the cause named.
  const std::uintmax_t limit_bytes = fs::file_size(out_dir / "curves.csv") / 2;
  const fs::path limited = dir / "limited";
  std::tie(rc, text) = testing::run_cli("prlimit --fsize=" + std::to_string(limit_bytes) + " " + cli,
                                        "stats learning " + csv.string() + " --no-figures --out " + limited.string());
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, HasSubstr((limited / "curves.csv").string() + ": cannot write: File too large"));
  EXPECT_FALSE(fs::exists(limited / "curves.csv")) << "a truncated curves.csv was left";
  EXPECT_TRUE(fs::is_empty(limited)) << "a temporary file was left";

  std::tie(rc, text) = testing::run_cli(cli, "stats transfer " + csv.string() + " --reference-group hifi");
  EXPECT_EQ(rc, 0) << text;
  // Changes: hifi (60 + p) -> (30 + p) = -30 each, lofi (60 + p) -> (25 + p) =
  // -35 each: completely separated, p = 2/20 exact, shift -5.
  EXPECT_THAT(text, HasSubstr("p = 0.1 (exact, 20 assignments)"));
  EXPECT_THAT(text, HasSubstr("Hodges-Lehmann shift lofi - hifi = -5 (no interval: groups of 3 and 3"));
  EXPECT_THAT(text, HasSubstr("refused: no control group declared"));

  std::tie(rc, text) = testing::run_cli(cli, "stats learning " + csv.string() + " --measure force_p95_N --out " + out_dir.string());
  EXPECT_NE(rc, 0);
  EXPECT_THAT(text, HasSubstr("force_p95_N"));
  std::tie(rc, text) = testing::run_cli(cli, "stats learning " + csv.string() + " --cusum-criterion 30 --p0 0.3 --p1 0.1 --out " + out_dir.string());
  EXPECT_NE(rc, 0);
  EXPECT_THAT(text, HasSubstr("p1 = 0.1 is refused (allowed: p1 > p0 = 0.3"));
  std::tie(rc, text) = testing::run_cli(cli, "stats transfer " + csv.string() + " --control-group nosim");
  EXPECT_NE(rc, 0);
  EXPECT_THAT(text, HasSubstr("control group 'nosim' has no participants"));
  {
    std::ofstream bad(dir / "nan.csv");
    bad << "participant,group,phase,trial,completion_time_s\nP1,a,training,1,nan\n";
  }
  std::tie(rc, text) = testing::run_cli(cli, "stats learning " + (dir / "nan.csv").string() + " --out " + out_dir.string());
  EXPECT_NE(rc, 0);
  EXPECT_THAT(text, HasSubstr("completion_time_s"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hapticlab
