#pragma once
// An HTTP/1.1 request as the console's server reads it, and the two parsers
// that read it off a socket's bytes with hard limits: the head (request
// line and headers) and the body (Content-Length or chunked). Both work on
// whatever has arrived so far and say "need more", so a connection that
// trickles its bytes never holds a thread; both refuse at once, with the
// status to answer and a message naming the limit, what goes past it.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hapticlab::console::http {

struct Limits {
  std::size_t max_head_bytes = 16 * 1024;  // request line and headers together
  std::size_t max_headers = 64;
  std::size_t max_body_bytes = 16 * 1024;  // decoded body, chunked or not (a route may allow less)
};

struct Request {
  std::string method;  // "GET", "POST", ...
  std::string target;  // as sent: "/results/a%20b.csv?x=1"
  std::string path;    // the target's path, percent-decoded: "/results/a b.csv"
  std::string query;   // after '?', as sent
  int minor_version = 1;  // HTTP/1.<minor>
  std::vector<std::pair<std::string, std::string>> headers;  // names in lower case, values trimmed
  std::string body;
  std::string admitted;  // what the route's admit() noted for its handler (http_server.h)

  // The value of header `lower_name` ("host"), or null when absent.
  const std::string* header(std::string_view lower_name) const;
  // HTTP/1.1 without "Connection: close", or HTTP/1.0 with "keep-alive".
  bool keep_alive() const;
};

// A refusal found while parsing: the status to answer and why.
struct ParseError {
  int status = 400;
  std::string message;
};

enum class ParseState : std::uint8_t { kNeedMore, kDone, kError };

// How the body is framed, from the head's headers.
struct BodyFraming {
  enum class Kind : std::uint8_t { kNone, kLength, kChunked } kind = Kind::kNone;
  std::uint64_t length = 0;  // kLength: Content-Length
};

// Parses a request head from the front of `bytes`. kDone: `out` holds the
// head, `consumed` the bytes it took (the body starts there). kNeedMore:
// nothing is consumed; call again with more bytes. kError: `error` says why
// (431 when the head outgrows limits.max_head_bytes before it ends, 400 for
// a malformed one, 505 for a version other than HTTP/1.0 and 1.1).
ParseState parse_head(std::string_view bytes, const Limits& limits, Request& out, std::size_t& consumed,
                      ParseError& error);

// The body's framing, or an error: Transfer-Encoding other than "chunked"
// (501), both it and Content-Length, or two Content-Lengths that differ
// (400: a proxy could read another request out of it), a Content-Length that
// is not a number (400).
bool body_framing(const Request& head, BodyFraming& framing, ParseError& error);

// Reads a body of either framing into a string, refusing (413) as soon as
// what was declared or decoded passes `max_bytes`, without waiting for the
// bytes themselves.
class BodyReader {
 public:
  BodyReader(BodyFraming framing, std::size_t max_bytes);

  // Takes what it can from the front of `bytes`, appends the decoded body
  // to `body`, sets `consumed`. kDone: the body is complete (bytes after it
  // belong to the next request).
  ParseState feed(std::string_view bytes, std::string& body, std::size_t& consumed, ParseError& error);

 private:
  enum class Step : std::uint8_t { kLengthBody, kChunkSize, kChunkData, kChunkDataEnd, kTrailer, kDone };
  BodyFraming framing_;
  std::size_t max_bytes_;
  Step step_;
  std::uint64_t left_ = 0;  // bytes of the body (kLength) or of this chunk still to come
};

// Decodes %XX escapes of a path; false for a malformed escape or a decoded
// NUL (neither names any file or route).
bool percent_decode_path(std::string_view in, std::string& out);

}  // namespace hapticlab::console::http
