#pragma once
// Whether a text is well-formed UTF-8 (RFC 3629): no overlong forms, no
// surrogates, nothing above U+10FFFF. Text an application hands in (a
// device name, a reason) is stored, exported to CSV and shown in reports
// and the console, where ill-formed bytes would become replacement
// characters or be refused by a JSON reader.

#include <string_view>

namespace hapticlab {

bool is_valid_utf8(std::string_view text) noexcept;

}  // namespace hapticlab
