#pragma once
// What text the study API stores: a device name and a trial's reason are
// stored with the session and trial, exported to CSV and shown to the
// operator, so they must be UTF-8, and say something where a reason is
// required. The rules, apart from the C API's bookkeeping.

#include <string>
#include <string_view>

namespace hapticlab::sessions {

// UTF-8 without control characters: C0, DEL, C1, U+2028/2029 and the
// bidirectional overrides and isolates (a newline, an escape sequence or a
// reordering would forge what the operator's terminal shows).
bool printable_name(std::string_view name);

// Empty, or white space only.
bool blank(std::string_view text);

// Why `why` cannot be stored as the reason of a trial ended with `outcome`
// (HL_TRIAL_*), or "": not UTF-8; blank for HL_TRIAL_ABORTED, which must
// say why in words; anything but blank for HL_TRIAL_COMPLETE, which has no
// column for a reason (dropping it without a word would lose what the
// application meant to say).
std::string reason_problem(int outcome, std::string_view why);

}  // namespace hapticlab::sessions
