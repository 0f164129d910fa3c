#pragma once
// An HTTP response as a route makes it, and its head as bytes on the wire.
// Every response carries the console's security headers (a page may not be
// framed by another, types are not sniffed, nothing is cached) unless the
// route sets its own value for one of them.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hapticlab::console::http {

struct Response {
  int status = 200;
  std::string content_type = "application/json";  // with its charset where it has one
  std::string body;
  // Sent after the body's own headers; a name given here replaces the
  // server's default for it (X-Frame-Options, Content-Security-Policy, ...).
  std::vector<std::pair<std::string, std::string>> headers;
  // Streamed as the body from the file, in pieces, instead of `body`.
  std::optional<std::filesystem::path> file;
  bool close = false;  // close the connection after this response

  static Response text(int status, std::string body, std::string content_type = "text/plain; charset=utf-8");
  // {"error": message} with `status`.
  static Response error(int status, const std::string& message);
  bool has_header(std::string_view name) const;  // case-insensitive
};

// "OK", "Not Found", ...: the reason phrase of a status the console uses.
const char* reason_phrase(int status) noexcept;

// The status line and headers, ending with the empty line. `content_length`:
// the body's length; nullopt for a stream, which ends when the connection
// closes. `defaults` are added for every name the response does not set.
std::string response_head(const Response& response, std::optional<std::size_t> content_length, bool keep_alive,
                          const std::vector<std::pair<std::string, std::string>>& defaults);

}  // namespace hapticlab::console::http
