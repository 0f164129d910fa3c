// The command line's conventions through the real binary: exit statuses
// (0, 1 failure, 2 usage), "hapticlab: error: ..." with the --help to read,
// a suggestion for a mistyped command, `hapticlab help [COMMAND...]`.
#include <string>
#include <utility>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli/cli_errors.h"
#include "app/cli_process.h"
#include "tests/testing/test_paths.h"

namespace hapticlab {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;


TEST(CliConventions, AMistypedCommandIsNamedWithTheNearestOneAtItsLevel) {
  auto [status, out] = testing::run_cli(kBinary, "stduy show");
  EXPECT_EQ(status, 2);
  EXPECT_THAT(out, StartsWith("hapticlab: error: 'stduy' is not a command; did you mean 'study'?"));
  EXPECT_THAT(out, HasSubstr("Run 'hapticlab --help'"));
  std::tie(status, out) = testing::run_cli(kBinary, "study shwo --db x.db");
  EXPECT_EQ(status, 2);
  EXPECT_THAT(out, HasSubstr("'shwo' is not a hapticlab study command; did you mean 'show'?"));
  std::tie(status, out) = testing::run_cli(kBinary, "frobnicate");
  EXPECT_EQ(status, 2);
  EXPECT_THAT(out, Not(HasSubstr("did you mean")));  // nothing is near: no misleading guess
}

TEST(CliConventions, UsageErrorsExitTwoAndNameTheCommandsHelp) {
  for (const char* args : {"study show", "session run --db x.db --participant S1 --rate-hz 5",
                           "session run --db x.db --participant S1 --device lsw", "analyze --no-such-option"}) {
    const auto [status, out] = testing::run_cli(kBinary, args);
    EXPECT_EQ(status, 2) << args << "\n" << out;
    EXPECT_THAT(out, StartsWith("hapticlab: error: ")) << args;
    EXPECT_THAT(out, HasSubstr("--help' for usage")) << args;
  }
}

TEST(CliConventions, AlphaIsCheckedAtTheOptionWithoutInternalNames) {
  for (const char* alpha : {"0", "1", "-0.1", "nan"}) {
    const auto [status, out] =
        testing::run_cli(kBinary, std::string("stats pairwise --control HF --csv none.csv --alpha ") + alpha);
    EXPECT_EQ(status, 2) << alpha << "\n" << out;
    EXPECT_THAT(out, HasSubstr("strictly between 0 and 1")) << alpha;
    EXPECT_THAT(out, Not(HasSubstr("()"))) << alpha;  // no function name reaches the user
  }
}

TEST(CliConventions, AFailureExitsOneWithTheCause) {
  const auto [status, out] = testing::run_cli(kBinary, "study show --db /nonexistent/study.db");
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("/nonexistent/study.db"));
}

TEST(CliConventions, HelpNamesCommandsAndExitStatuses) {
  auto [status, out] = testing::run_cli(kBinary, "");
  EXPECT_EQ(status, 0);
  EXPECT_THAT(out, HasSubstr("Usage: hapticlab [OPTIONS] SUBCOMMAND"));
  EXPECT_THAT(out, HasSubstr("session"));
  EXPECT_THAT(out, HasSubstr("Exit status: 0 success; 1 "));
  std::tie(status, out) = testing::run_cli(kBinary, "help study create");
  EXPECT_EQ(status, 0);
  EXPECT_THAT(out, HasSubstr("Usage: hapticlab study create [OPTIONS]"));
  EXPECT_THAT(out, HasSubstr("--protocol"));
  std::tie(status, out) = testing::run_cli(kBinary, "help");
  EXPECT_EQ(status, 0);
  EXPECT_THAT(out, HasSubstr("Usage: hapticlab [OPTIONS] SUBCOMMAND"));
  std::tie(status, out) = testing::run_cli(kBinary, "help sesion");
  EXPECT_EQ(status, 2);
  EXPECT_THAT(out, HasSubstr("did you mean 'session'?"));
}

TEST(CliConventions, OldSpellingsStillWorkForOneReleaseButAreHidden) {
  const std::string settings = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/friction.json";
  const std::string csv = ::testing::TempDir() + "hapticlab_old_spelling.csv";
  auto [status, out] = testing::run_cli(
      kBinary, "sim run --task clip --settings " + settings + " --max-duration-s 0.2 --output " + csv);
  EXPECT_EQ(status, 4) << out;  // ran (and timed out, as asked)
  EXPECT_THAT(out, HasSubstr("after 0.20 s"));
  std::tie(status, out) = testing::run_cli(kBinary, "sim run --help");
  EXPECT_THAT(out, HasSubstr("--out"));
  EXPECT_THAT(out, HasSubstr("--max-trial-s"));
  EXPECT_THAT(out, Not(HasSubstr("--output")));
  EXPECT_THAT(out, Not(HasSubstr("--max-duration-s")));
  EXPECT_THAT(out, Not(HasSubstr("Excludes:")));  // once printed empty under --out
  std::tie(status, out) = testing::run_cli(
      kBinary, "sim run --task clip --settings " + settings + " --out " + csv + " --output " + csv);
  EXPECT_EQ(status, 2) << out;  // both spellings at once
  std::tie(status, out) = testing::run_cli(kBinary, "settings check -q " + settings);  // positional, as before
  EXPECT_EQ(status, 0) << out;
  // An error of the old spelling names it (CLI11 left the name of a hidden
  // option out: "error:  excludes --csv", "error: : File does not exist").
  std::tie(status, out) = testing::run_cli(kBinary, "engine replay --settings " + settings + " --csv " + csv +
                                                        " --input " + csv + " --out " + csv + ".out");
  EXPECT_EQ(status, 2) << out;
  EXPECT_THAT(out, HasSubstr("error: --input excludes --csv")) << out;
  std::tie(status, out) = testing::run_cli(kBinary, "engine replay --settings " + settings +
                                                        " --input /nonexistent.csv --out " + csv + ".out");
  EXPECT_EQ(status, 2) << out;
  EXPECT_THAT(out, HasSubstr("error: --input: File does not exist: /nonexistent.csv")) << out;
  // Every file is checked, a missing one too (the parse stopped at it).
  std::tie(status, out) = testing::run_cli(kBinary, "settings check -q " + settings + " /nonexistent.json " + settings);
  EXPECT_EQ(status, 1) << out;
  EXPECT_THAT(out, HasSubstr("/nonexistent.json: cannot open settings file")) << out;
}

// A device preset's source is printed before its settings (issue 19 §3).
TEST(CliConventions, SettingsCheckPrintsADevicePresetsSource) {
  const std::string preset = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/devices/novint_falcon.json";
  const auto [status, out] = testing::run_cli(kBinary, "settings check --settings " + preset);
  EXPECT_EQ(status, 0) << out;
  EXPECT_THAT(out, HasSubstr("Source: Novint Falcon\n  reference: [1] CHAI3D 3.3.0"));
  EXPECT_THAT(out, HasSubstr("\n  back-drive inertia: not published in the cited sources"));
  EXPECT_THAT(out, HasSubstr("\n  peak force: more than 8.9 N, vendor-stated"));
  EXPECT_THAT(out, HasSubstr("tip_force_saturation.limit_N = 8.9, the floor the vendor gives\n"));
}

TEST(CliConventions, NearestNameIsForTyposOnly) {
  const std::vector<std::string> names = {"study", "session", "stats", "export"};
  EXPECT_EQ(app::nearest_name("sesion", names), "session");
  EXPECT_EQ(app::nearest_name("stat", names), "stats");
  EXPECT_EQ(app::nearest_name("calibrate", names), "");
}

// The recurring option shapes (app/cli/option_shapes.h) are one
// definition: every command that takes --rate-hz, --seed or --jobs refuses
// the same values in the same words, naming the option, the value and the
// range.
TEST(CliConventions, TheRecurringOptionShapesAreRefusedAlikeByEveryCommand) {
  const std::string rate = "is refused: must be a finite number from 150 to 2000";
  const std::string seed = "'-1' is refused: must be a whole number from 0 to 18446744073709551615";
  const std::string jobs = "'257' is refused: must be a whole number from 0 to 256";
  const std::pair<const char*, std::string> cases[] = {
      {"session run --rate-hz 149", "--rate-hz: '149' " + rate},
      {"sim run --rate-hz 2001", "--rate-hz: '2001' " + rate},
      {"plan power --rate-hz 149", "--rate-hz: '149' " + rate},
      {"plan calibrate --rate-hz 149", "--rate-hz: '149' " + rate},
      {"device check --rate-hz 149", "--rate-hz: '149' " + rate},
      {"bench loop --rate-hz 149", "--rate-hz: '149' " + rate},
      {"bench udp --rate-hz 149", "--rate-hz: '149' " + rate},
      {"plan power --seed -1", "--seed: " + seed},
      {"plan calibrate --seed -1", "--seed: " + seed},
      {"analyze --seed -1", "--seed: " + seed},
      {"stats ks --seed -1", "--seed: " + seed},
      {"plan power --jobs 257", "--jobs: " + jobs},
      {"plan calibrate -j 257", "--jobs: " + jobs},
      {"analyze --jobs 257", "--jobs: " + jobs},
      {"stability map --jobs 257", "--jobs: " + jobs},
      // Hexadecimal, which strtod reads (0x2 = 2): refused as the whole
      // numbers refuse it.
      {"sim run --rate-hz 0x3e8", "--rate-hz: '0x3e8' " + rate},
  };
  for (const auto& [args, refusal] : cases) {
    const auto [status, out] = testing::run_cli(kBinary, args);
    EXPECT_EQ(status, 2) << args << "\n" << out;
    EXPECT_THAT(out, StartsWith("hapticlab: error: " + refusal)) << args;
  }
}

}  // namespace
}  // namespace hapticlab
