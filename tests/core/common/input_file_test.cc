// Bounded reads and the strict JSON parser shared by settings and protocols.
#include "core/common/input_file.h"

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

std::string error_of_json(const std::string& text) {
  try {
    parse_json_strict(text);
  } catch (const InputFileError& e) {
    return e.what();
  }
  return "(accepted)";
}

std::string nested_arrays(int depth) { return std::string(depth, '[') + std::string(depth, ']'); }

TEST(ReadTextFile, EndlessDeviceIsRefusedAtTheLimit) {
  try {
    read_text_file("/dev/zero", 1000, "test file");
    FAIL() << "/dev/zero was read";
  } catch (const InputFileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("/dev/zero: larger than 1000 bytes, the limit for a test file"));
  }
}

TEST(ReadTextFile, FileOfExactlyTheLimitIsRead) {
  const fs::path path = fs::path(::testing::TempDir()) / "input_file_test_exact.txt";
  std::ofstream(path, std::ios::binary) << std::string(1024, 'x');
  EXPECT_EQ(read_text_file(path, 1024, "test file").size(), 1024u);
  EXPECT_THROW(read_text_file(path, 1023, "test file"), InputFileError);
  fs::remove(path);
}

TEST(ReadTextFile, MissingFileNamesPathAndCause) {
  try {
    read_text_file("/nonexistent/x.json", 1000, "settings file");
    FAIL();
  } catch (const InputFileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("/nonexistent/x.json: cannot open settings file: No such file"));
  }
}

TEST(FormatByteLimit, UsesTheLargestExactUnit) {
  EXPECT_EQ(format_byte_limit(kMaxJsonFileBytes), "4 MiB");
  EXPECT_EQ(format_byte_limit(2048), "2 KiB");
  EXPECT_EQ(format_byte_limit(1000), "1000 bytes");
}

TEST(ParseJsonStrict, DepthUpToTheLimitIsAcceptedAndOneMoreIsNot) {
  EXPECT_NO_THROW(parse_json_strict(nested_arrays(kMaxJsonDepth)));
  EXPECT_THAT(error_of_json(nested_arrays(kMaxJsonDepth + 1)), HasSubstr("nested more than 64 levels"));
}

TEST(ParseJsonStrict, HundredThousandLevelsAreRefusedWithoutRecursion) {
  // Unbalanced on purpose: the refusal must come before the end is seen.
  const std::string deep = std::string(100000, '[');
  EXPECT_THAT(error_of_json(deep), HasSubstr("nested more than 64 levels"));
  const std::string objects = [] {
    std::string s;
    for (int i = 0; i < 100000; ++i) s += "{\"a\":";
    return s;
  }();
  const std::string message = error_of_json(objects);
  EXPECT_THAT(message, HasSubstr("nested more than 64 levels deep (at 'a.a.a."));
  EXPECT_LT(message.size(), 300u);  // the path is shortened
}

TEST(ParseJsonStrict, TrailingNulIsRefusedWithItsPosition) {
  EXPECT_THAT(error_of_json(std::string("{}\n\0", 4)), HasSubstr("NUL byte at line 2, column 1 (byte 4 of 4)"));
  EXPECT_THAT(error_of_json(std::string("{\"a\":1}\0garbage", 15)), HasSubstr("NUL byte"));
}

TEST(ParseJsonStrict, TrailingGarbageIsRefused) {
  EXPECT_THAT(error_of_json("{} x"), HasSubstr("not valid JSON"));
  EXPECT_THAT(error_of_json("{}{}"), HasSubstr("not valid JSON"));
  EXPECT_NO_THROW(parse_json_strict("{} \n\t\r\n"));
}

TEST(ParseJsonStrict, DuplicateKeyIsRefusedWithItsPath) {
  EXPECT_EQ(error_of_json(R"({"a": 1, "a": 2})"),
            "key 'a' appears twice in the top-level object; each key may be given once");
  EXPECT_THAT(error_of_json(R"({"t": {"s": {"level_N": 1, "x": 0, "level_N": 2}}})"),
              HasSubstr("key 'level_N' appears twice in object 't.s'"));
  EXPECT_THAT(error_of_json(R"({"p": [{"k": 1}, {"k": 1, "k": 2}]})"),
              HasSubstr("key 'k' appears twice in object 'p[1]'"));
  // The same key in sibling objects is fine.
  EXPECT_NO_THROW(parse_json_strict(R"({"a": {"k": 1}, "b": {"k": 1}, "c": [{"k": 1}, {"k": 2}]})"));
}

TEST(ParseJsonStrict, NumberBeyondADoubleIsRefused) {
  EXPECT_THAT(error_of_json(R"({"a": 1e999})"), HasSubstr("not valid JSON"));
}

TEST(ParseJsonStrict, ReturnsTheDocument) {
  const nlohmann::json j = parse_json_strict(R"({"a": [1, 2.5, "x"], "b": {"c": null}})");
  EXPECT_EQ(j["a"][1].get<double>(), 2.5);
  EXPECT_TRUE(j["b"]["c"].is_null());
}

TEST(VisibleText, NamesInvisibleCharacters) {
  EXPECT_EQ(visible_text("\xEF\xBB\xBFparticipant"), "<U+FEFF>participant");
  EXPECT_EQ(visible_text("a\rb\tc\x01"), "a\\rb\\tc\\x01");
  EXPECT_EQ(visible_text("plain, text"), "plain, text");
}

}  // namespace
}  // namespace hapticlab
