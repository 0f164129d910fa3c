#pragma once
// The current time as ISO 8601 UTC to the second, "2026-11-26T12:09:19Z":
// what a report or a log stamps its lines with.
#include <string>

namespace hapticlab {

std::string utc_now_iso8601();

}  // namespace hapticlab
