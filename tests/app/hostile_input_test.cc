// Issue 14, section 3: hostile input through the real binary. Each case must
// end with a message that says what is wrong, exit status 1, and no partial
// output file.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "tests/testing/test_paths.h"
#include "tests/testing/files.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

const fs::path kExamples = fs::path(HAPTICLAB_SOURCE_DIR) / "examples";

const char* const kTrajectoryHeader =
    "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N";

class HostileInputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("hapticlab_hostile_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& text) const {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  // `prefix` goes before the binary (e.g. "prlimit --fsize=4096 ").
  static std::pair<int, std::string> run(const std::string& args, const std::string& prefix = "") {
    return testing::run_cli(prefix + kBinary, args);
  }

  // Files in the scratch directory other than the inputs named.
  std::size_t entries() const {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++n;
    return n;
  }

  // n rows per instrument of a valid trajectory, in the given line ending.
  static std::string trajectory(int n, const std::string& eol = "\n") {
    std::string s = kTrajectoryHeader + eol;
    for (int i = 0; i < n; ++i) {
      for (int instrument = 0; instrument < 2; ++instrument) {
        s += std::to_string(i * 0.001) + "," + std::to_string(instrument) + ",0.1,0,0,0,0,-1" + eol;
      }
    }
    return s;
  }

  std::string settings_arg() const { return (kExamples / "settings" / "friction.json").string(); }

  fs::path dir_;
};

using testing::slurp;

// ---------------------------------------------------------------- JSON

TEST_F(HostileInputTest, SettingsNestedHundredThousandDeepIsRefused) {
  // A field's value nested 100,000 deep: the old loader crashed (SIGSEGV)
  // printing it in its error message.
  const fs::path deep = write("deep.json", R"({"name": "x", "translation": {"friction": {"dynamic_level_N": )" +
                                               std::string(100000, '[') + std::string(100000, ']') + "}}}");
  const auto [status, out] = run("settings check " + deep.string());
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr(deep.string() + ": arrays and objects are nested more than 64 levels deep (at "
                                             "'translation.friction.dynamic_level_N[0][0]"));
  EXPECT_LT(out.size(), 1000u) << "the error must not echo the document";
}

TEST_F(HostileInputTest, ProtocolNestedHundredThousandDeepIsRefusedByStudyCreate) {
  // The old reader crashed (SIGSEGV) on this well-formed document.
  const fs::path deep = write("deep.json", "{\"study\": " + std::string(100000, '[') + std::string(100000, ']') + "}");
  const auto [status, out] = run("study create --protocol " + deep.string() + " --db " + (dir_ / "s.db").string());
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("nested more than 64 levels deep (at 'study[0][0][0]"));
  EXPECT_FALSE(fs::exists(dir_ / "s.db"));
}

TEST_F(HostileInputTest, SettingsCheckOfDevZeroStopsAtTheSizeLimit) {
  const auto [status, out] = run("settings check --settings /dev/zero");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("/dev/zero: larger than 4 MiB, the limit for a settings file"));
}

TEST_F(HostileInputTest, SettingsFollowedByANulByteAreRefused) {
  const fs::path path = write("nul.json", slurp(settings_arg()) + std::string(1, '\0'));
  const auto [status, out] = run("settings check " + path.string());
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr(path.string() + ": not valid JSON: NUL byte at line"));
}

TEST_F(HostileInputTest, DuplicateKeyInSettingsIsRefusedAndNamed) {
  const fs::path path = write(
      "dup.json", R"({"name": "x", "translation": {"saturation": {"level_N": 1.0, "level_N": 3.0}}})");
  const auto [status, out] = run("settings check " + path.string());
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("key 'level_N' appears twice in object 'translation.saturation'"));
}

TEST_F(HostileInputTest, DuplicateKeyInProtocolIsRefusedAndNamed) {
  std::string text = slurp(kExamples / "protocols" / "thesis_quick.json");
  const auto brace = text.find('{');
  ASSERT_NE(brace, std::string::npos);
  text.insert(brace + 1, "\"seed\": 1, \"seed\": 2,");
  // Relative settings paths resolve against the protocol's directory.
  const fs::path path = kExamples / "protocols" / ("dup_seed_" + std::to_string(::getpid()) + ".json");
  std::ofstream(path, std::ios::binary) << text;
  const auto [status, out] = run("study create --protocol " + path.string() + " --db " + (dir_ / "s.db").string());
  fs::remove(path);
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("key 'seed' appears twice in the top-level object"));
  EXPECT_FALSE(fs::exists(dir_ / "s.db"));
}

// ---------------------------------------------------------------- CSV

TEST_F(HostileInputTest, StatsReadsACsvWithAByteOrderMark) {
  const fs::path csv = write("bom.csv", "\xEF\xBB\xBFx,y\n1,2\n2,4.1\n3,5.9\n4,8.2\n5,9.9\n");
  const auto [status, out] = run("stats correlation --csv " + csv.string() + " --x x --y y");
  EXPECT_EQ(status, 0) << out;
  EXPECT_THAT(out, Not(HasSubstr("no column")));
}

TEST_F(HostileInputTest, StatsNamesInvisibleCharactersInColumnNames) {
  // A zero-width space before the x, as copied from a web page.
  const fs::path csv = write("zwsp.csv", "\xE2\x80\x8Bx,y\n1,2\n2,4.1\n3,5.9\n");
  const auto [status, out] = run("stats correlation --csv " + csv.string() + " --x x --y y");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("the columns are: <U+200B>x, y"));
}

TEST_F(HostileInputTest, StatsReadsACsvWithCrOnlyLineEndings) {
  const fs::path csv = write("cr.csv", "x,y\r1,2\r2,4.1\r3,5.9\r4,8.2\r5,9.9\r");
  const fs::path lf = write("lf.csv", "x,y\n1,2\n2,4.1\n3,5.9\n4,8.2\n5,9.9\n");
  const auto [status, out] = run("stats correlation --csv " + csv.string() + " --x x --y y");
  const auto [lf_status, lf_out] = run("stats correlation --csv " + lf.string() + " --x x --y y");
  EXPECT_EQ(status, 0) << out;
  EXPECT_EQ(lf_status, 0) << lf_out;
  // Same data, same answer, apart from the file name.
  EXPECT_EQ(out.substr(out.find(csv.string()) + csv.string().size()),
            lf_out.substr(lf_out.find(lf.string()) + lf.string().size()));
}

TEST_F(HostileInputTest, EngineReplayReadsBomAndCrOnlyTrajectories) {
  const fs::path input = write("cr.csv", "\xEF\xBB\xBF" + trajectory(3, "\r"));
  const fs::path output = dir_ / "out.csv";
  const auto [status, out] = run("engine replay --settings " + settings_arg() + " --csv " + input.string() +
                                 " --out " + output.string());
  EXPECT_EQ(status, 0) << out;
  EXPECT_THAT(out, HasSubstr("6 rows (instrument 0: 3, instrument 1: 3)"));
}

TEST_F(HostileInputTest, CsvInputsOfDevZeroStopAtTheirLimits) {
  const auto [stats_status, stats_out] = run("stats correlation --csv /dev/zero --x x --y y");
  EXPECT_EQ(stats_status, 1) << stats_out;
  EXPECT_THAT(stats_out, HasSubstr("/dev/zero: larger than 64 MiB, the limit for a CSV file"));

  const auto [replay_status, replay_out] = run("engine replay --settings " + settings_arg() +
                                               " --csv /dev/zero --out " + (dir_ / "out.csv").string());
  EXPECT_EQ(replay_status, 1) << replay_out;
  // A device is not read at all: replay reads its --csv twice.
  EXPECT_THAT(replay_out, HasSubstr("--csv /dev/zero: not a regular file"));
  EXPECT_EQ(entries(), 0u);
}

// ---------------------------------------------------------------- outputs

TEST_F(HostileInputTest, EngineReplayOntoAFullDeviceNamesPathAndCause) {
  const fs::path input = write("in.csv", trajectory(3));
  // Through a link in the scratch directory: a binary that renamed a
  // temporary file over its output would replace the link, not the
  // machine's /dev/full.
  const fs::path output = dir_ / "full.csv";
  fs::create_symlink("/dev/full", output);
  const auto [status, out] = run("engine replay --settings " + settings_arg() + " --csv " + input.string() +
                                 " --out " + output.string());
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr(output.string() + ": cannot write: No space left on device"));
}

// A file size limit (prlimit, util-linux) fails the write part-way, as a
// full disk does (EFBIG instead of ENOSPC).
TEST_F(HostileInputTest, EngineReplayOverTheFileSizeLimitLeavesNoOutput) {
  const fs::path input = write("in.csv", trajectory(2000));  // output about 600 KB
  const fs::path output = dir_ / "out.csv";
  const auto [status, out] = run("engine replay --settings " + settings_arg() + " --csv " + input.string() +
                                     " --out " + output.string(),
                                 "prlimit --fsize=32768 ");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr(output.string() + ": cannot write: File too large"));
  EXPECT_FALSE(fs::exists(output));
  EXPECT_EQ(entries(), 1u) << "only the input may be left";
}

TEST_F(HostileInputTest, SimRunOverTheFileSizeLimitLeavesNoOutput) {
  const fs::path output = dir_ / "sim.csv";
  const auto [status, out] = run("sim run --settings " + settings_arg() + " --max-trial-s 2 --out " +
                                     output.string(),
                                 "prlimit --fsize=8192 ");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr(output.string() + ": cannot write: File too large"));
  EXPECT_EQ(entries(), 0u);
}

TEST_F(HostileInputTest, EngineReplayRefusesToOverwriteItsInput) {
  const std::string text = trajectory(3);
  const fs::path input = write("in.csv", text);
  fs::create_symlink(input, dir_ / "link.csv");
  for (const fs::path& output : {input, dir_ / "." / "in.csv", dir_ / "link.csv"}) {
    const auto [status, out] = run("engine replay --settings " + settings_arg() + " --csv " + input.string() +
                                   " --out " + output.string());
    EXPECT_EQ(status, 1) << out;
    EXPECT_THAT(out, HasSubstr("is the same file as --csv"));
  }
  EXPECT_EQ(slurp(input), text);
}

}  // namespace
}  // namespace hapticlab
