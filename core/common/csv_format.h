#pragma once
// The one way HapticLab writes a CSV field, used by every writer (export,
// metrics.csv, engine replay), so a file from one command reads the same as
// a file from another.
//
// Text follows RFC 4180: a field is quoted only when it holds a comma, a
// quote or a line break, and a quote inside is doubled. Numbers are the
// shortest text that std::from_chars / strtod read back to the same value
// (std::to_chars without a precision): 0.1 is "0.1", never "0.100000001" or
// "0.10000000000000001", and a printed value round-trips exactly.
#include <charconv>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>

namespace hapticlab {

// Appends `text` to `line` as one CSV field.
inline void append_csv_text(std::string& line, std::string_view text) {
  if (text.find_first_of(",\"\r\n") == std::string_view::npos) {
    line += text;
    return;
  }
  line += '"';
  for (char c : text) {
    if (c == '"') line += '"';
    line += c;
  }
  line += '"';
}

inline std::string csv_text(std::string_view text) {
  std::string out;
  append_csv_text(out, text);
  return out;
}

// Appends the shortest round-trip form of an integer or floating-point value
// (non-finite doubles come out as "inf", "-inf", "nan"; callers that must not
// write those check first).
template <typename T>
void append_number(std::string& line, T value) {
  static_assert(std::is_arithmetic_v<T> && !std::is_same_v<T, bool>);
  char buf[40];  // enough for any double or 64-bit integer
  const auto r = std::to_chars(buf, buf + sizeof buf, value);
  line.append(buf, r.ec == std::errc{} ? r.ptr : buf);
}

template <typename T>
std::string format_number(T value) {
  std::string out;
  append_number(out, value);
  return out;
}

}  // namespace hapticlab
