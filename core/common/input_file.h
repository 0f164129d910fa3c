#pragma once
// Reading user-supplied input files safely: a size cap on every read, and one
// strict JSON parser for settings and protocol files.
//
// A path given by a user may name anything: /dev/zero, a FIFO, a directory, a
// file damaged by a crash, or a document built to exhaust memory or stack.
// Every read here is bounded, and a refusal names the file, what was found
// and the limit.

#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

namespace hapticlab {

// What an input file broke; what() is the whole message, the path first.
class InputFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Settings and protocol files are a few kilobytes; a protocol for hundreds of
// participants is well under a megabyte.
inline constexpr std::size_t kMaxJsonFileBytes = std::size_t{4} << 20;  // 4 MiB
// The deepest real document (a protocol's design.assignments lists) is 4
// levels deep; the limit keeps every recursive walk of the tree shallow.
inline constexpr int kMaxJsonDepth = 64;
// Long-format CSV files for `stats` are read whole; the metrics.csv of a
// study of 100,000 trials is about 30 MB.
inline constexpr std::size_t kMaxCsvFileBytes = std::size_t{64} << 20;  // 64 MiB
// Streamed CSV files (trajectories) have no size limit, but one line must fit
// in memory: a real row is about 200 bytes.
inline constexpr std::size_t kMaxCsvLineBytes = std::size_t{1} << 20;  // 1 MiB

// "4 MiB", "1 MiB", "512 bytes": a limit as a message shows it.
std::string format_byte_limit(std::size_t bytes);

// The whole file, at most `max_bytes` of it. Anything longer (including
// endless devices such as /dev/zero) is refused with "<path>: larger than
// <limit>, the limit for a <what>"; errors from open or read name the path
// and the cause ("<path>: cannot open <what>: No such file or directory").
// `what` is e.g. "settings file".
std::string read_text_file(const std::filesystem::path& path, std::size_t max_bytes,
                           std::string_view what);

// Parses one JSON document and refuses, with a message that says where:
//   - a NUL byte anywhere (nlohmann's lexer treats NUL as the end of the
//     input, so "{}\0garbage" would otherwise be accepted);
//   - anything but whitespace after the document;
//   - nesting deeper than kMaxJsonDepth arrays/objects (a 100,000-deep
//     document would otherwise overflow the stack of any recursive walk);
//   - a key given twice in one object (nlohmann keeps the last silently);
//   - a number beyond the range of a double.
// The message does not name the source; callers prefix it. It starts with
// "not valid JSON: " for syntax errors, and names the key and its path for
// duplicates, e.g. "key 'level_N' appears twice in object 'translation.saturation'".
nlohmann::json parse_json_strict(std::string_view text);

// A string for messages with invisible and control characters made visible:
// U+FEFF (byte order mark) as "<U+FEFF>", CR as "\r", TAB as "\t", other
// bytes below 0x20 and DEL as "\xNN".
std::string visible_text(std::string_view s);

}  // namespace hapticlab
