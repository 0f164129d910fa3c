#include "sessions/capi/study_text.h"

#include "core/common/utf8.h"
#include "hapticlab/study.h"

namespace hapticlab::sessions {

bool printable_name(std::string_view name) {
  if (!is_valid_utf8(name)) return false;
  for (std::size_t i = 0; i < name.size();) {
    const auto [c, n] = utf8_char_at(name, i);
    // C0 and DEL, C1 (a CSI starts an escape sequence), the line and
    // paragraph separators, and the bidirectional overrides and isolates,
    // which reorder what a terminal or a report shows around them.
    if (c < 0x20 || (c >= 0x7F && c <= 0x9F) || c == 0x2028 || c == 0x2029 || (c >= 0x202A && c <= 0x202E) ||
        (c >= 0x2066 && c <= 0x2069))
      return false;
    i += n;
  }
  return true;
}

bool blank(std::string_view text) { return text.find_first_not_of(" \t\r\n\v\f") == std::string_view::npos; }

std::string reason_problem(int outcome, std::string_view why) {
  if (!is_valid_utf8(why)) return "reason is not valid UTF-8 (it is stored, exported and shown as text)";
  if (outcome == HL_TRIAL_ABORTED && blank(why))
    return std::string("reason is required for HL_TRIAL_ABORTED (it is stored with the trial)") +
           (why.empty() ? "" : "; it holds only white space");
  if (outcome == HL_TRIAL_COMPLETE && !blank(why)) {
    std::size_t cut = why.size() > 60 ? 57 : why.size();
    while (cut < why.size() && (static_cast<unsigned char>(why[cut]) & 0xC0) == 0x80) --cut;  // whole characters
    const std::string shown = std::string(why.substr(0, cut)) + (cut < why.size() ? "..." : "");
    return "a complete trial stores no reason (given: \"" + shown +
           "\"); pass NULL, or end it HL_TRIAL_ABORTED if that is what it says";
  }
  return {};
}

}  // namespace hapticlab::sessions
