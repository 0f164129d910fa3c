#include "core/common/utf8.h"

#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

TEST(Utf8, WellFormedTextIsAccepted) {
  EXPECT_TRUE(is_valid_utf8(""));
  EXPECT_TRUE(is_valid_utf8("Phantom Premium 1.5"));
  EXPECT_TRUE(is_valid_utf8("Zürich \xC2\xB5m"));                  // 2 bytes: ü, µ
  EXPECT_TRUE(is_valid_utf8("\xE2\x82\xAC \xEF\xBF\xBD"));          // 3 bytes: €, U+FFFD
  EXPECT_TRUE(is_valid_utf8("\xF0\x9F\x91\x8D \xF4\x8F\xBF\xBF"));  // 4 bytes, U+10FFFF
  EXPECT_TRUE(is_valid_utf8(std::string("a\0b", 3)));              // NUL is a character
}

TEST(Utf8, IllFormedTextIsRefused) {
  for (const char* bad : {
           "dev\xff\xfe",         // bytes that never occur
           "\x80",                // a continuation byte first
           "\xC3",                // cut short
           "\xE2\x82",            // cut short
           "\xC0\xAF",            // overlong '/'
           "\xC1\xBF",            // overlong
           "\xE0\x80\xAF",        // overlong, 3 bytes
           "\xF0\x80\x80\xAF",    // overlong, 4 bytes
           "\xED\xA0\x80",        // a surrogate (U+D800)
           "\xF4\x90\x80\x80",    // above U+10FFFF
           "\xF5\x80\x80\x80",    // F5 is never a lead
           "\xE2\x28\xA1",        // second byte not a continuation
           "\xF0\x9F\x91\x28",    // fourth byte not a continuation
       }) {
    EXPECT_FALSE(is_valid_utf8(bad)) << ::testing::PrintToString(std::string(bad));
  }
}

// Decoded by hand: é = C3 A9 (U+00E9), € = E2 82 AC (U+20AC), 👍 = F0 9F 91
// 8D (U+1F44D); a stray byte, and a sequence the text cuts short, are one
// byte each.
TEST(Utf8, CharactersAreDecodedWithTheirLength) {
  const std::string text = "a\xC3\xA9\xE2\x82\xAC\xF0\x9F\x91\x8D\xFF\xE2\x82";
  const std::vector<std::pair<char32_t, std::size_t>> want = {
      {U'a', 1}, {0xE9, 2}, {0x20AC, 3}, {0x1F44D, 4}, {0xFF, 1}, {0xE2, 1}, {0x82, 1}};
  std::size_t i = 0;
  for (const auto& [code_point, bytes] : want) {
    const Utf8Char c = utf8_char_at(text, i);
    EXPECT_EQ(c.code_point, code_point) << i;
    EXPECT_EQ(c.bytes, bytes) << i;
    i += c.bytes;
  }
  EXPECT_EQ(i, text.size());
}

}  // namespace
}  // namespace hapticlab
