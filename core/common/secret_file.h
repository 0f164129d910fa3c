#pragma once
// Secrets kept in files: the console's control token and the UDP bridge's
// HMAC key. One reader, so both refuse the same mistakes with the same
// words: a file others can read, a CRLF line end taken as part of the
// secret, a secret made of spaces or of one repeated character.
//
// The file holds the secret on its first line. One trailing "\n" or "\r\n"
// is not part of it; anything else is (a second line is refused).

#include <cstddef>
#include <filesystem>
#include <string>

namespace hapticlab {

struct SecretRules {
  std::size_t min_chars = 16;      // the secret's length, after the line end is removed
  std::size_t min_distinct = 8;    // different characters in it: "aaaa…" or "abab…" is a typo, not a secret
  bool hex_only = false;           // [0-9a-fA-F] only (an HMAC key, decoded with hex_bytes)
};

// Reads the secret of `path`. `what` names it in messages ("--token-file",
// "device-option key_file"). Throws std::invalid_argument naming the path
// and the rule broken: a missing or non-regular file, a mode that lets the
// group or others read or write it (printed in octal: "mode 0644; chmod
// 600 it"), more than 4 kB, a second line, a NUL, whitespace or a control
// character in it, fewer than rules.min_chars characters or
// rules.min_distinct distinct ones, a non-hex character when hex_only.
std::string read_secret_file(const std::filesystem::path& path, const std::string& what,
                             const SecretRules& rules = {});

// `bytes` random bytes from the kernel (getrandom), as lower-case hex.
// Throws std::runtime_error if the kernel gives none.
std::string random_hex(std::size_t bytes);

// Creates `path` with mode 0600 holding `secret` and a "\n"; refuses to
// replace an existing file (O_EXCL). Throws std::runtime_error naming the
// path and the cause.
void create_secret_file(const std::filesystem::path& path, const std::string& secret);

// Hex digits to bytes ("0aff" -> {0x0a, 0xff}); throws std::invalid_argument
// for an odd length or a non-hex character.
std::string hex_bytes(const std::string& hex);

}  // namespace hapticlab
