// `hapticlab device serve-sim`'s options, through the real binary: the
// far side of the UDP bridge refuses what the host side refuses.
//
// `--key-file ""` (a script's empty variable) used to serve without any
// authentication, where the host refuses `key_file=` ("names no file");
// `--key-file K --insecure` was accepted, where the host refuses the pair;
// and `--host localhost` was "refused: serving beyond loopback without a
// key", where the address is simply not a numeric IPv4 one.
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/app/cli_process.h"
#include "tests/testing/scratch_dir.h"

namespace hapticlab::app {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

const std::string kServeSimCli = HAPTICLAB_CLI_PATH;

class ServeSimOptionsTest : public ::testing::Test {
 protected:
  // serve-sim for at most 5 s: one that serves runs until stopped, so a
  // wrongly accepted option shows as a stopped server rather than a hang.
  static std::pair<int, std::string> serve_sim(const std::string& args) {
    return testing::run_shell("timeout --preserve-status -s INT 5 " + kServeSimCli + " device serve-sim --port 0 " + args +
                              " 2>&1");
  }
  hapticlab::testing::ScratchDir scratch_{"hapticlab_serve_sim_"};
};

TEST_F(ServeSimOptionsTest, AnEmptyKeyFileIsRefusedRatherThanServingWithoutAKey) {
  const auto [code, out] = serve_sim("--key-file ''");
  EXPECT_EQ(code, 2) << out;
  EXPECT_THAT(out, HasSubstr("--key-file: names no file"));
  EXPECT_THAT(out, Not(HasSubstr("serving the simulated workstation")));
}

TEST_F(ServeSimOptionsTest, AKeyFileWithInsecureIsRefusedAsTheHostRefusesIt) {
  const std::string key = (scratch_.path() / "k.key").string();
  const auto [made, made_out] = testing::run_cli(kServeSimCli, "device keygen --out " + key);
  ASSERT_EQ(made, 0) << made_out;
  const auto [code, out] = serve_sim("--key-file " + key + " --insecure");
  EXPECT_EQ(code, 2) << out;
  EXPECT_THAT(out, HasSubstr("--insecure and --key-file " + key + " together"));
  EXPECT_THAT(out, Not(HasSubstr("serving the simulated workstation")));
}

TEST_F(ServeSimOptionsTest, AHostThatIsNoIpv4AddressIsRefusedAsSuchBeforeLoopbackIsJudged) {
  for (const std::string& host : {std::string("localhost"), std::string("127.1"), std::string("")}) {
    const auto [code, out] = serve_sim("--host '" + host + "'");
    EXPECT_EQ(code, 2) << host << "\n" << out;
    EXPECT_THAT(out, HasSubstr("--host '" + host + "': not a numeric IPv4 address")) << host;
    EXPECT_THAT(out, Not(HasSubstr("beyond loopback"))) << host;
  }
  // Another loopback address needs no key (127.0.0.0/8).
  const auto [code, out] = serve_sim("--host 127.0.0.2");
  EXPECT_EQ(code, 0) << out;
  EXPECT_THAT(out, HasSubstr("serving the simulated workstation on udp:127.0.0.2:"));
}

// A port out of range was the server's error (exit 1) where a port that is
// no number was a usage error (exit 2); both are usage errors now.
TEST_F(ServeSimOptionsTest, APortOutOfRangeIsAUsageErrorNamingTheRange) {
  for (const std::string port : {"65536", "-1", "abc"}) {
    const auto [code, out] =
        testing::run_shell("timeout 5 " + kServeSimCli + " device serve-sim --port " + port + " 2>&1");
    EXPECT_EQ(code, 2) << port << "\n" << out;
    EXPECT_THAT(out, HasSubstr("--port: '" + port + "' is refused: must be a whole number from 0 to 65535")) << out;
  }
}

}  // namespace
}  // namespace hapticlab::app
