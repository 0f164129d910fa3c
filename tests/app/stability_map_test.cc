// `hapticlab stability map` through the real binary: tables and figures
// written, the same bytes on any number of threads, and a grid too large
// for five minutes refused with its estimate until --yes.
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/app/cli_process.h"
#include "tests/testing/scratch_dir.h"
#include "tests/testing/files.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class StabilityMapCommandTest : public ::testing::Test {
 protected:
  std::pair<int, std::string> map(const std::string& args) {
    return testing::run_cli(HAPTICLAB_CLI_PATH, "stability map " + args);
  }
  hapticlab::testing::ScratchDir scratch_{"hapticlab_smap_"};
  const fs::path dir_ = scratch_.path();
};

TEST_F(StabilityMapCommandTest, WritesTablesAndFiguresTheSameOnAnyNumberOfThreads) {
  const std::string grid = "--rates 300,150 --stiffness 2000 --effects translation.inertia.damping_ratio --steps 5 ";
  const auto [rc, out] = map(grid + "--jobs 1 --out " + (dir_ / "one").string());
  ASSERT_EQ(rc, 0) << out;
  const auto [rc2, out2] = map(grid + "--jobs 2 --no-plots --out " + (dir_ / "two").string());
  ASSERT_EQ(rc2, 0) << out2;
  const std::string csv = testing::slurp(dir_ / "one" / "stability_map.csv");
  EXPECT_EQ(csv, testing::slurp(dir_ / "two" / "stability_map.csv"));
  EXPECT_EQ(testing::slurp(dir_ / "one" / "stability_map.md"), testing::slurp(dir_ / "two" / "stability_map.md"));
  EXPECT_EQ(testing::slurp(dir_ / "one" / "stability_base.csv"), testing::slurp(dir_ / "two" / "stability_base.csv"));
  // Rates sorted; off and on for each; the base (0.3) unstable without the
  // controller at 2 kN/m and a lower boundary found above it.
  EXPECT_THAT(csv, HasSubstr("field,effect,contact,stiffness_N_per_m,rate_Hz,controller,range_lo,range_hi,base_value,"
                             "base_stable,below_kind,below_stable,below_unstable,above_kind,above_stable,"
                             "above_unstable\n"
                             "translation.inertia.damping_ratio,inertia,grasped,2000,150,off,0,2,0.3,0,"
                             "unstable_everywhere,,0,stable_above,"));
  EXPECT_THAT(out, HasSubstr("| the base settings themselves | | | **unstable**"));
  EXPECT_THAT(out, HasSubstr("| `translation.inertia.damping_ratio` | 0 – 2 | 0.3 | ✗ ≥ "));
  EXPECT_TRUE(fs::exists(dir_ / "one" / "map_translation_inertia_damping_ratio.svg"));
  EXPECT_TRUE(fs::exists(dir_ / "one" / "plots.gp"));
  EXPECT_FALSE(fs::exists(dir_ / "two" / "plots.gp"));
}

TEST_F(StabilityMapCommandTest, AGridTooLargeForFiveMinutesAsksForYes) {
  // 16 parameters x 14 rates x 2 stiffnesses x 2, runs of 10 minutes each.
  const auto [rc, out] = map("--rates 150,200,300,400,500,600,700,800,900,1000,1200,1500,1800,2000 "
                             "--duration-s 600 --out " + (dir_ / "big").string());
  EXPECT_EQ(rc, 1) << out;
  EXPECT_THAT(out, HasSubstr("hapticlab: error: the grid is large: up to 40376 runs, estimated "));
  EXPECT_THAT(out, HasSubstr("Pass --yes to run it anyway, or make it smaller (--rates, --effects, --stiffness, "
                             "--steps, --duration-s)"));
  EXPECT_FALSE(fs::exists(dir_ / "big"));
}

TEST_F(StabilityMapCommandTest, BadGridsAreRefusedNamingTheOption) {
  const auto [rc, out] = map("--effects inertia,viscosity --out " + (dir_ / "x").string());
  EXPECT_EQ(rc, 2) << out;
  EXPECT_THAT(out, HasSubstr("'viscosity' is not one of: inertia, backlash, cogging, friction, "
                             "translation.inertia.mass_kg"));
  const auto [rc2, out2] = map("--rates 100 --out " + (dir_ / "x").string());
  EXPECT_EQ(rc2, 2) << out2;
  EXPECT_THAT(out2, HasSubstr("--rates"));
  EXPECT_FALSE(fs::exists(dir_ / "x"));
}

}  // namespace
}  // namespace hapticlab::app
