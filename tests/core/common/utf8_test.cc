#include "core/common/utf8.h"

#include <string>

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

}  // namespace
}  // namespace hapticlab
