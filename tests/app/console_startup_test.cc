// `hapticlab console`'s start-up, through the real binary: what it refuses
// before it listens, and that a refusal changes nothing on disk.
//
// A --db that is no study (an empty file, a JSON file) used to be opened
// read-write first: SQLite made the empty file a 94 KB database and a
// token file appeared beside each, before "holds no study". A plugin that
// is no plugin was found only at the first session. --bind was judged by
// its spelling (127.0.0.2 "needed --token-file", "" too), and one port for
// both sites failed only when the second could not listen.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/app/cli_process.h"
#include "tests/testing/scratch_dir.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kConsoleCli = HAPTICLAB_CLI_PATH;

// Every entry of `dir` with its size and a hash of its bytes: two listings
// are equal only if no file was added, removed or changed (and a failure
// prints a line per file, not the files).
std::map<std::string, std::string> directory_bytes(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(dir)) {
    std::string digest = "directory";
    if (e.is_regular_file()) {
      std::ifstream in(e.path(), std::ios::binary);
      const std::string bytes(std::istreambuf_iterator<char>(in), {});
      digest = std::to_string(bytes.size()) + " bytes, hash " + std::to_string(std::hash<std::string>{}(bytes));
    }
    files[fs::relative(e.path(), dir).string()] = digest;
  }
  return files;
}

class ConsoleStartupTest : public ::testing::Test {
 protected:
  // The console for at most `seconds` (a console that starts serves until
  // stopped; SIGINT stops it as Ctrl-C does, and it exits 0). Returns the
  // status and the output.
  static std::pair<int, std::string> console(const std::string& args, int seconds = 8) {
    return testing::run_shell("timeout --preserve-status -s INT " + std::to_string(seconds) + " " + kConsoleCli + " console " + args +
                              " 2>&1");
  }
  std::string create_study(const std::string& name) const {
    const std::string db = (dir_ / name).string();
    const auto [code, out] = testing::run_cli(kConsoleCli, "study create --protocol " + std::string(HAPTICLAB_SOURCE_DIR) +
                                                           "/examples/protocols/thesis_quick.json --db " + db);
    EXPECT_EQ(code, 0) << out;
    return db;
  }
  hapticlab::testing::ScratchDir scratch_{"hapticlab_console_"};
  const fs::path dir_ = scratch_.path();
};

// A --db that holds no study is refused before anything is written: no
// token file, no SQLite database made of an empty file, no journal.
TEST_F(ConsoleStartupTest, ARefusedDbLeavesTheDirectoryExactlyAsItWas) {
  std::ofstream(dir_ / "e2.db").close();  // 0 bytes
  fs::copy_file(fs::path(HAPTICLAB_SOURCE_DIR) / "examples/settings/high_fidelity.json", dir_ / "hf.json");
  ASSERT_EQ(testing::run_shell(std::string(HAPTICLAB_SQLITE3_CLI) + " " + (dir_ / "other.db").string() + " 'CREATE TABLE t(a)'").first, 0);
  ASSERT_EQ(testing::run_shell(std::string(HAPTICLAB_SQLITE3_CLI) + " " + (dir_ / "blank.db").string() + " 'CREATE TABLE t(a); DROP TABLE t'").first,
            0);
  const std::map<std::string, std::string> before = directory_bytes(dir_);
  for (const auto& [file, why] : std::vector<std::pair<std::string, std::string>>{
           {"e2.db", "the file is empty: it holds no study"},
           {"hf.json", "expected a HapticLab study database"},
           {"other.db", "not a HapticLab study database"},
           {"blank.db", "holds no study"}}) {
    const std::string db = (dir_ / file).string();
    const auto [code, out] = console("--db " + db + " --port 0");
    EXPECT_EQ(code, 1) << file << "\n" << out;
    EXPECT_THAT(out, HasSubstr("--db: " + db)) << file;
    EXPECT_THAT(out, HasSubstr(why)) << file;
    EXPECT_THAT(out, Not(HasSubstr("console token"))) << file;
    EXPECT_EQ(directory_bytes(dir_), before) << file << ": the refused console changed the directory";
  }
}

// The same start-up order for the other refusals: nothing is made first.
TEST_F(ConsoleStartupTest, OnePortForBothSitesIsRefusedByNameBeforeListening) {
  const std::string db = create_study("s.db");
  const std::map<std::string, std::string> before = directory_bytes(dir_);
  const auto [code, out] = console("--db " + db + " --port 47613 --participant-port 47613");
  EXPECT_EQ(code, 2) << out;
  EXPECT_THAT(out, HasSubstr("--participant-port 47613: the same port as --port"));
  EXPECT_THAT(out, Not(HasSubstr("cannot listen")));
  EXPECT_EQ(directory_bytes(dir_), before) << "the refused console made its token file";
}

// A plugin file is checked at start-up (it exists, is a regular file, an
// ELF shared library), as a bad udp: address or device option is refused
// there, not at the first session.
TEST_F(ConsoleStartupTest, APluginThatIsNoPluginIsRefusedAtStartUp) {
  const std::string db = create_study("s.db");
  const fs::path text = dir_ / "notplugin.so";
  std::ofstream(text) << "not a shared library\n";
  fs::create_directory(dir_ / "plugins");
  for (const auto& [path, why] : std::vector<std::pair<std::string, std::string>>{
           {text.string(), "is not a shared library (no ELF header)"},
           {(dir_ / "plugins").string(), "is a directory"},
           {(dir_ / "missing.so").string(), "no such file"}}) {
    const std::map<std::string, std::string> before = directory_bytes(dir_);
    const auto [code, out] = console("--db " + db + " --port 0 --device plugin:" + path);
    EXPECT_EQ(code, 1) << path << "\n" << out;
    EXPECT_THAT(out, HasSubstr("--device plugin:" + path + ": ")) << path;
    EXPECT_THAT(out, HasSubstr(why)) << path;
    EXPECT_THAT(out, Not(HasSubstr("console: http://"))) << path;
    EXPECT_EQ(directory_bytes(dir_), before) << path;
  }
}

// Loopback is 127.0.0.0/8, judged on the parsed address as serve-sim does;
// an address that does not parse is refused as such.
TEST_F(ConsoleStartupTest, BindIsJudgedOnTheParsedAddress) {
  const std::string db = create_study("s.db");
  auto [code, out] = console("--db " + db + " --port 0 --bind 127.0.0.2", 4);
  EXPECT_THAT(out, Not(HasSubstr("needs --token-file"))) << out;
  EXPECT_THAT(out, HasSubstr("console: http://127.0.0.2:")) << out;
  EXPECT_EQ(code, 0) << out;  // stopped by the SIGINT

  for (const std::string& bind : {std::string("''"), std::string("localhost.invalid"), std::string("127.1")}) {
    std::tie(code, out) = console("--db " + db + " --port 0 --bind " + bind);
    EXPECT_EQ(code, 2) << bind << "\n" << out;
    EXPECT_THAT(out, HasSubstr("--bind ")) << bind;
    EXPECT_THAT(out, HasSubstr("is not an IP address")) << bind;
    EXPECT_THAT(out, Not(HasSubstr("needs --token-file"))) << bind;
  }

  // Beyond loopback: the warning says what is true. Reads need the token
  // too (docs/console.md, "Security"); 192.0.2.1 (TEST-NET-1) is no address
  // of this machine, so nothing listens after the warning.
  const std::string token = (dir_ / "token").string();
  std::tie(code, out) = console("--db " + db + " --port 0 --bind 192.0.2.1 --token-file " + token);
  EXPECT_EQ(code, 1) << out;
  EXPECT_THAT(out, HasSubstr("warning: the console listens on 192.0.2.1"));
  EXPECT_THAT(out, Not(HasSubstr("sees the study's progress")));
  EXPECT_THAT(out, HasSubstr("the study's data and every control need the token in " + token));
  EXPECT_THAT(out, Not(HasSubstr("in the address below"))) << "the token line promised an address never printed";
}

// The start-up check does not load the plugin: none of its code runs in
// the console (a review found its static constructors running there,
// unsupervised, for plugin-isolated: too). A library without the entry
// point is therefore found when a session loads it, not here: the console
// starts.
TEST_F(ConsoleStartupTest, APluginIsNotLoadedIntoTheConsoleAtStartUp) {
  const std::string db = create_study("s.db");
  const auto [code, out] =
      console("--db " + db + " --port 0 --device plugin-isolated:" + std::string(HAPTICLAB_FAKE_PLUGIN_NO_ENTRY_PATH), 4);
  EXPECT_THAT(out, HasSubstr("console: http://")) << out;
  EXPECT_THAT(out, Not(HasSubstr("does not export"))) << out;
  EXPECT_EQ(code, 0) << out;  // stopped by the SIGINT
}

// A console that cannot listen (its port taken) made its token file before
// it found out, and left it (a review): a refused start leaves the
// directory as it was.
TEST_F(ConsoleStartupTest, AConsoleThatCannotListenLeavesNoTokenFile) {
  const std::string db = create_study("s.db");
  const int taken = ::socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(taken, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(taken, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  ASSERT_EQ(::listen(taken, 1), 0);
  socklen_t length = sizeof address;
  ASSERT_EQ(::getsockname(taken, reinterpret_cast<sockaddr*>(&address), &length), 0);
  const int port = ntohs(address.sin_port);
  const std::map<std::string, std::string> before = directory_bytes(dir_);
  const auto [code, out] = console("--db " + db + " --port " + std::to_string(port));
  ::close(taken);
  EXPECT_EQ(code, 1) << out;
  EXPECT_THAT(out, HasSubstr("cannot listen")) << out;
  EXPECT_EQ(directory_bytes(dir_), before) << "the refused console left its token file";
}

}  // namespace
}  // namespace hapticlab::app
