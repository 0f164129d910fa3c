#pragma once
// Whether a text is well-formed UTF-8 (RFC 3629): no overlong forms, no
// surrogates, nothing above U+10FFFF. Text an application hands in (a
// device name, a reason) is stored, exported to CSV and shown in reports
// and the console, where ill-formed bytes would become replacement
// characters or be refused by a JSON reader.

#include <cstddef>
#include <string_view>

namespace hapticlab {

bool is_valid_utf8(std::string_view text) noexcept;

// The character that starts at byte `i` of `text` (i < text.size()): its
// code point and length in bytes. A byte that cannot start a character, or
// a sequence cut short by the text's end, is read as that one byte, so
// ill-formed text is still walked to its end (check is_valid_utf8 first
// where that matters).
struct Utf8Char {
  char32_t code_point = 0;
  std::size_t bytes = 1;
};
Utf8Char utf8_char_at(std::string_view text, std::size_t i) noexcept;

}  // namespace hapticlab
