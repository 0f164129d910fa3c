// Secret files: the mistakes the console's token file and the UDP bridge's
// key file must refuse, each named.
#include "core/common/secret_file.h"

#include <sys/stat.h>

#include <fstream>
#include <set>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "testing/scratch_dir.h"

namespace hapticlab {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

fs::path write_secret(const fs::path& dir, const std::string& name, const std::string& content, mode_t mode) {
  const fs::path p = dir / name;
  std::ofstream(p, std::ios::binary) << content;
  ::chmod(p.c_str(), mode);
  return p;
}

std::string refusal(const fs::path& p, const SecretRules& rules = {}) {
  try {
    read_secret_file(p, "--token-file", rules);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(SecretFile, ReadsTheFirstLineWithoutItsLineEnd) {
  testing::ScratchDir dir;
  const std::string token = "0123456789abcdef0123";
  EXPECT_EQ(read_secret_file(write_secret(dir.path(), "lf", token + "\n", 0600), "t"), token);
  // A file saved on Windows: the CR is the line end, not part of the token.
  EXPECT_EQ(read_secret_file(write_secret(dir.path(), "crlf", token + "\r\n", 0600), "t"), token);
  EXPECT_EQ(read_secret_file(write_secret(dir.path(), "bare", token, 0400), "t"), token);
}

TEST(SecretFile, RefusesAFileOthersCanReadNamingItsModeInOctal) {
  testing::ScratchDir dir;
  const std::string why = refusal(write_secret(dir.path(), "open", "0123456789abcdef\n", 0644));
  EXPECT_THAT(why, HasSubstr("mode 0644"));
  EXPECT_THAT(why, HasSubstr("chmod 600"));
  EXPECT_THAT(refusal(write_secret(dir.path(), "group", "0123456789abcdef\n", 0620)), HasSubstr("mode 0620"));
}

TEST(SecretFile, RefusesWeakOrMalformedSecrets) {
  testing::ScratchDir dir;
  EXPECT_THAT(refusal(write_secret(dir.path(), "spaces", std::string(20, ' ') + "\n", 0600)), HasSubstr("a space"));
  EXPECT_THAT(refusal(write_secret(dir.path(), "a16", std::string(16, 'a') + "\n", 0600)),
              HasSubstr("only 1 different characters"));
  EXPECT_THAT(refusal(write_secret(dir.path(), "short", "0123456789abc\n", 0600)), HasSubstr("holds 13 characters"));
  EXPECT_THAT(refusal(write_secret(dir.path(), "two", "0123456789abcdef\nsecond\n", 0600)),
              HasSubstr("more than one line"));
  EXPECT_THAT(refusal(write_secret(dir.path(), "cr", "0123456789abcdef\r\r\n", 0600)),
              HasSubstr("control character 13"));
  EXPECT_THAT(refusal(write_secret(dir.path(), "nul", std::string("0123456789\0abcdef", 17), 0600)),
              HasSubstr("control character 0"));
  EXPECT_THAT(refusal(dir.path() / "missing"), HasSubstr("cannot open it"));
  EXPECT_THAT(refusal(dir.path()), HasSubstr("not a regular file"));
  SecretRules hex;
  hex.hex_only = true;
  EXPECT_THAT(refusal(write_secret(dir.path(), "nothex", "0123456789abcdefg\n", 0600), hex),
              HasSubstr("'g') is not a hex digit"));
}

TEST(SecretFile, CreatesA0600FileAndNeverReplacesOne) {
  testing::ScratchDir dir;
  const std::string secret = random_hex(16);
  ASSERT_EQ(secret.size(), 32u);
  EXPECT_GE(std::set<char>(secret.begin(), secret.end()).size(), 8u);  // 16 random bytes: fewer is ~1e-9
  EXPECT_NE(random_hex(16), secret);
  const fs::path p = dir.path() / "token";
  create_secret_file(p, secret);
  struct stat st {};
  ASSERT_EQ(::stat(p.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_EQ(read_secret_file(p, "t"), secret);
  EXPECT_THROW(create_secret_file(p, "another"), std::runtime_error);
  EXPECT_EQ(read_secret_file(p, "t"), secret);
}

TEST(SecretFile, DecodesHex) {
  EXPECT_EQ(hex_bytes("00ff7fA0"), std::string("\x00\xff\x7f\xa0", 4));
  EXPECT_THROW(hex_bytes("abc"), std::invalid_argument);
  EXPECT_THROW(hex_bytes("zz"), std::invalid_argument);
}

}  // namespace
}  // namespace hapticlab
