// `hapticlab engine demo` through the real binary: a --settings-dir without
// the nine settings files it feels the motion through, or an --out that
// cannot be a folder, is refused by name before anything is printed or
// written; --help names the nine files.
#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/app/cli_process.h"
#include "tests/testing/scratch_dir.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

// The files the demo reads, in its order (Table 3.1's, then max_stable).
const char* const kDemoSettings[] = {"high_fidelity", "no_force_feedback", "inertia",
                                     "inertia_backlash", "friction", "cogging",
                                     "force_saturation", "all_degradations", "max_stable"};

class EngineDemoCommandTest : public ::testing::Test {
 protected:
  std::pair<int, std::string> demo(const std::string& args) {
    return testing::run_cli(HAPTICLAB_CLI_PATH, "engine demo --seconds 0.1 " + args);
  }
  // A settings folder holding copies of the shipped files named.
  fs::path settings_dir(const std::string& name, std::initializer_list<const char*> files) {
    const fs::path dir = dir_ / name;
    fs::create_directories(dir);
    for (const char* f : files)
      fs::copy_file(fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings" / (std::string(f) + ".json"),
                    dir / (std::string(f) + ".json"));
    return dir;
  }
  hapticlab::testing::ScratchDir scratch_{"hapticlab_edemo_"};
  const fs::path dir_ = scratch_.path();
};

// A missing folder, or one with some of the files, printed the banner and
// the table's header and failed at the first missing file, the CSVs of the
// files before it written; neither --help nor the error named the files.
TEST_F(EngineDemoCommandTest, ASettingsDirWithoutTheNineFilesIsRefusedBeforeAnything) {
  const fs::path out = dir_ / "out";
  auto [rc, text] = demo("--settings-dir " + (dir_ / "nowhere").string() + " --out " + out.string());
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, AllOf(HasSubstr("--settings-dir '" + (dir_ / "nowhere").string() + "'"),
                          HasSubstr("is not a folder"), Not(HasSubstr("HapticLab engine demo")),
                          Not(HasSubstr("peak N"))));
  for (const char* f : kDemoSettings) EXPECT_THAT(text, HasSubstr(std::string(f) + ".json"));
  EXPECT_FALSE(fs::exists(out));

  const fs::path some = settings_dir("some", {"high_fidelity", "friction", "cogging"});
  std::tie(rc, text) = demo("--settings-dir " + some.string() + " --out " + out.string());
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, AllOf(HasSubstr("--settings-dir '" + some.string() + "': 6 of the 9 settings files the demo "
                                    "needs are missing: no_force_feedback.json, inertia.json, "
                                    "inertia_backlash.json, force_saturation.json, all_degradations.json, "
                                    "max_stable.json"),
                          Not(HasSubstr("HapticLab engine demo"))));
  EXPECT_FALSE(fs::exists(out));

  // All there, the last one damaged: nothing written for the eight before it.
  const fs::path all = settings_dir("all", {"high_fidelity", "no_force_feedback", "inertia", "inertia_backlash",
                                            "friction", "cogging", "force_saturation", "all_degradations",
                                            "max_stable"});
  std::ofstream(all / "max_stable.json") << "{\"name\": \"Max\", \"translation\": {\"inertia\": {\"mass_kg\": -1}}}";
  std::tie(rc, text) = demo("--settings-dir " + all.string() + " --out " + out.string());
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, AllOf(HasSubstr("max_stable.json"), HasSubstr("translation.inertia.mass_kg"),
                          Not(HasSubstr("HapticLab engine demo"))));
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(EngineDemoCommandTest, HelpNamesTheNineSettingsFiles) {
  const auto [rc, text] = testing::run_cli(HAPTICLAB_CLI_PATH, "engine demo --help");
  EXPECT_EQ(rc, 0) << text;
  for (const char* f : kDemoSettings) EXPECT_THAT(text, HasSubstr(std::string(f) + ".json"));
}

// --out naming a file gave "filesystem error: cannot create directories:
// Not a directory [afile]", and --out '' "... Invalid argument []".
TEST_F(EngineDemoCommandTest, AnUnusableOutIsNamedBeforeAnythingIsPrinted) {
  std::ofstream(dir_ / "afile") << "x";
  auto [rc, text] = demo("--out " + (dir_ / "afile").string());
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, AllOf(HasSubstr("--out '" + (dir_ / "afile").string() + "': exists and is not a folder"),
                          Not(HasSubstr("filesystem error")), Not(HasSubstr("HapticLab engine demo"))));
  std::tie(rc, text) = demo("--out ''");
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, AllOf(HasSubstr("--out is empty"), Not(HasSubstr("filesystem error"))));
  std::tie(rc, text) = demo("--out /proc/sys");
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, AllOf(HasSubstr("--out '/proc/sys': cannot write in the folder"),
                          Not(HasSubstr("HapticLab engine demo"))));
}

}  // namespace
}  // namespace hapticlab::app
