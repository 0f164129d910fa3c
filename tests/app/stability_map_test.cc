// `hapticlab stability map` through the real binary: tables and figures
// written, the same bytes on any number of threads, and a grid too large
// for five minutes refused with its estimate until --yes.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/app/cli_process.h"
#include "tests/testing/scratch_dir.h"
#include "tests/testing/files.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

// How often `needle` occurs in `text`.
std::size_t occurrences(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1)) ++n;
  return n;
}

// The smallest map that runs: one rate, one parameter, one bisection step,
// the shortest runs (well under a second).
const std::string kTinyMap = "--rates 1000 --steps 1 --duration-s 1.5 --no-plots -j 1 ";

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
                             "above_unstable,base_effect\n"
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

// A stiffness given twice was mapped twice: two sections of the table, two
// result cells per row under one rate, every CSV row twice and twice the
// runs. It is merged, as a repeated rate is.
TEST_F(StabilityMapCommandTest, ARepeatedStiffnessIsMappedOnce) {
  const auto [rc, out] = map(kTinyMap + "--stiffness 320,320 --effects translation.inertia.damping_ratio --out " +
                             (dir_ / "map").string());
  ASSERT_EQ(rc, 0) << out;
  EXPECT_THAT(out, HasSubstr("x 1 rates x 1 stiffnesses x controller off/on"));
  const std::string md = testing::slurp(dir_ / "map" / "stability_map.md");
  EXPECT_EQ(occurrences(md, "## Grasped tissue, 320 N/m"), 1u) << md;
  // One result cell per row: "| parameter | range | base | result |".
  EXPECT_EQ(occurrences(md, "| `translation.inertia.damping_ratio` | 0 – 2 | 0.3 | "), 2u) << md;
  for (const std::string line : {"\n| `translation.inertia.damping_ratio`", "\n| the base settings themselves"})
    for (std::size_t at = md.find(line); at != std::string::npos; at = md.find(line, at + 1))
      EXPECT_EQ(occurrences(md.substr(at + 1, md.find('\n', at + 1) - at - 1), " |"), 4u) << md;
  // A header and one row per controller state.
  EXPECT_EQ(occurrences(testing::slurp(dir_ / "map" / "stability_map.csv"), "\n"), 3u);
  EXPECT_EQ(occurrences(testing::slurp(dir_ / "map" / "stability_base.csv"), "\n"), 3u);
}

// With a base file whose varied effect is off (High Fidelity or Inertia
// have no friction), the table showed the disabled block's value as
// "base", as if the base settings had it. The map runs with the effect on
// from that value; the table and the CSV say that it is off in the base
// (and on for inertia, which Inertia has).
TEST_F(StabilityMapCommandTest, AnEffectOffInTheBaseSettingsIsShownAsOff) {
  const std::string settings = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/inertia.json";
  const auto [rc, out] = map(kTinyMap + "--stiffness 320 --settings " + settings +
                             " --effects translation.friction.dynamic_level_N,translation.inertia.damping_ratio "
                             "--out " + (dir_ / "map").string());
  ASSERT_EQ(rc, 0) << out;
  const std::string md = testing::slurp(dir_ / "map" / "stability_map.md");
  EXPECT_THAT(md, HasSubstr("| `translation.friction.dynamic_level_N` | 0 – 50 | off (map from 0.45) | "));
  EXPECT_THAT(md, Not(HasSubstr("| 0 – 50 | 0.45 |")));
  EXPECT_THAT(md, HasSubstr("| `translation.inertia.damping_ratio` | 0 – 2 | 0.3 | "));
  EXPECT_THAT(md, HasSubstr("`off (map from v)`"));
  const std::string csv = testing::slurp(dir_ / "map" / "stability_map.csv");
  EXPECT_THAT(csv, HasSubstr(",above_unstable,base_effect\n"));
  EXPECT_THAT(csv, HasSubstr("translation.friction.dynamic_level_N,friction,grasped,320,1000,off,0,50,0.45,"));
  for (std::size_t at = csv.find("\ntranslation."); at != std::string::npos; at = csv.find("\ntranslation.", at + 1)) {
    const std::string row = csv.substr(at + 1, csv.find('\n', at + 1) - at - 1);
    EXPECT_THAT(row, ::testing::EndsWith(row.starts_with("translation.friction") ? ",off" : ",on"));
  }
}

// The default --effects includes backlash, which needs inertia on; with a
// base file without inertia (friction.json) the map failed with exit 1
// only after announcing itself, timing the machine and running cells,
// leaving an empty --out. It is refused before anything, naming --effects,
// what the effect needs, the file and both ways out.
TEST_F(StabilityMapCommandTest, AnEffectTheBaseCannotSwitchOnIsRefusedBeforeAnyRun) {
  const std::string settings = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/friction.json";
  const auto [rc, out] = map(kTinyMap + "--stiffness 320 --settings " + settings + " --out " + (dir_ / "x").string());
  EXPECT_EQ(rc, 2) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("--effects"), HasSubstr("translation.backlash"), HasSubstr("rotation.backlash"),
                         HasSubstr("needs 'translation.inertia' enabled"), HasSubstr(settings),
                         HasSubstr("--effects inertia,cogging,friction"),
                         HasSubstr("or a base settings file (--settings) with 'translation.inertia' enabled")));
  EXPECT_THAT(out, Not(HasSubstr("Stability map of")));
  EXPECT_FALSE(fs::exists(dir_ / "x"));
}

// An --out that cannot be a folder gave the library's "filesystem error:
// cannot create directories: Not a directory [afile]"; one that cannot be
// written was found only after the whole map ran.
TEST_F(StabilityMapCommandTest, AnUnusableOutIsNamedBeforeTheMapRuns) {
  std::ofstream(dir_ / "afile") << "x";
  const std::string grid = kTinyMap + "--stiffness 320 --effects translation.inertia.damping_ratio ";
  auto [rc, out] = map(grid + "--out " + (dir_ / "afile").string());
  EXPECT_EQ(rc, 1) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("--out '" + (dir_ / "afile").string() + "': exists and is not a folder"),
                         Not(HasSubstr("filesystem error")), Not(HasSubstr("runs in"))));
  std::tie(rc, out) = map(grid + "--out ''");
  EXPECT_EQ(rc, 1) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("--out is empty"), Not(HasSubstr("filesystem error"))));
  std::tie(rc, out) = map(grid + "--out /proc/sys");
  EXPECT_EQ(rc, 1) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("--out '/proc/sys': cannot write in the folder"), Not(HasSubstr("runs in"))));
}

}  // namespace
}  // namespace hapticlab::app
