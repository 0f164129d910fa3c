#include "console/http/http_request.h"

#include <algorithm>
#include <cctype>

namespace hapticlab::console::http {
namespace {

constexpr std::size_t kMaxChunkLine = 1024;  // "1a2b;ext=..." up to its CRLF

bool is_token_char(char c) {
  const auto u = static_cast<unsigned char>(c);
  if (std::isalnum(u)) return true;
  return std::string_view("!#$%&'*+-.^_`|~").find(c) != std::string_view::npos;
}

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

ParseState parse_fail(ParseError& error, int status, std::string message) {
  error.status = status;
  error.message = std::move(message);
  return ParseState::kError;
}

// The end of the head: the first empty line (CRLF CRLF; a bare LF is
// taken as a line end too, as RFC 9112 allows a server to).
std::size_t head_end(std::string_view bytes, std::size_t& terminator) {
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (bytes[i] != '\n') continue;
    if (i + 1 < bytes.size() && bytes[i + 1] == '\n') {
      terminator = 2;
      return i;
    }
    if (i + 2 < bytes.size() && bytes[i + 1] == '\r' && bytes[i + 2] == '\n') {
      terminator = 3;
      return i;
    }
  }
  return std::string_view::npos;
}

}  // namespace

const std::string* Request::header(std::string_view lower_name) const {
  for (const auto& [name, value] : headers)
    if (name == lower_name) return &value;
  return nullptr;
}

bool Request::keep_alive() const {
  const std::string* c = header("connection");
  const std::string v = c ? lower(*c) : std::string();
  if (minor_version == 0) return v.find("keep-alive") != std::string::npos;
  return v.find("close") == std::string::npos;
}

bool percent_decode_path(std::string_view in, std::string& out) {
  out.clear();
  for (std::size_t i = 0; i < in.size(); ++i) {
    if (in[i] != '%') {
      out += in[i];
      continue;
    }
    if (i + 2 >= in.size()) return false;
    const int hi = hex_value(in[i + 1]), lo = hex_value(in[i + 2]);
    if (hi < 0 || lo < 0) return false;
    const char c = static_cast<char>(hi * 16 + lo);
    if (c == '\0') return false;
    out += c;
    i += 2;
  }
  return true;
}

ParseState parse_head(std::string_view bytes, const Limits& limits, Request& out, std::size_t& consumed,
                      ParseError& error) {
  // Empty lines before a request line are allowed (RFC 9112, 2.2).
  std::size_t skip = 0;
  while (skip < bytes.size() && (bytes[skip] == '\r' || bytes[skip] == '\n')) ++skip;
  const std::string_view rest = bytes.substr(skip);
  std::size_t terminator = 0;
  const std::size_t end = head_end(rest, terminator);
  const bool too_long = end == std::string_view::npos ? rest.size() > limits.max_head_bytes
                                                      : end + terminator > limits.max_head_bytes;
  if (too_long)
    return parse_fail(error, 431, "request head: more than " + std::to_string(limits.max_head_bytes) +
                                " bytes of request line and headers");
  if (end == std::string_view::npos) return ParseState::kNeedMore;
  const std::string_view head = rest.substr(0, end + 1);
  consumed = skip + end + terminator;
  out = Request{};

  std::size_t line_start = 0;
  bool first = true;
  while (line_start < head.size()) {
    std::size_t nl = head.find('\n', line_start);
    if (nl == std::string_view::npos) nl = head.size();
    std::string_view line = head.substr(line_start, nl - line_start);
    line_start = nl + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) continue;
    if (first) {
      first = false;
      const std::size_t sp1 = line.find(' ');
      const std::size_t sp2 = sp1 == std::string_view::npos ? sp1 : line.find(' ', sp1 + 1);
      if (sp2 == std::string_view::npos || line.find(' ', sp2 + 1) != std::string_view::npos)
        return parse_fail(error, 400, "request line: not \"METHOD TARGET HTTP/1.1\"");
      out.method = std::string(line.substr(0, sp1));
      out.target = std::string(line.substr(sp1 + 1, sp2 - sp1 - 1));
      const std::string_view version = line.substr(sp2 + 1);
      if (out.method.empty() || !std::all_of(out.method.begin(), out.method.end(), is_token_char))
        return parse_fail(error, 400, "request line: the method is not a token");
      if (version == "HTTP/1.1") out.minor_version = 1;
      else if (version == "HTTP/1.0") out.minor_version = 0;
      else if (version.starts_with("HTTP/")) return parse_fail(error, 505, "HTTP version " + std::string(version) + ": only 1.0 and 1.1");
      else return parse_fail(error, 400, "request line: no HTTP version");
      if (out.target.empty() || out.target.front() != '/')
        return parse_fail(error, 400, "request target: must be a path starting with '/'");
      const std::size_t q = out.target.find('?');
      const std::string_view raw_path = std::string_view(out.target).substr(0, q);
      if (q != std::string::npos) out.query = out.target.substr(q + 1);
      if (!percent_decode_path(raw_path, out.path))
        return parse_fail(error, 400, "request target: a malformed %-escape or an encoded NUL in the path");
      continue;
    }
    if (line.front() == ' ' || line.front() == '\t')
      return parse_fail(error, 400, "header: a folded (continued) line; not accepted");
    const std::size_t colon = line.find(':');
    if (colon == std::string_view::npos || colon == 0)
      return parse_fail(error, 400, "header: a line without \"name: value\"");
    const std::string_view name = line.substr(0, colon);
    if (!std::all_of(name.begin(), name.end(), is_token_char))
      return parse_fail(error, 400, "header: the name '" + std::string(name.substr(0, 64)) + "' is not a token");
    const std::string_view value = trim(line.substr(colon + 1));
    for (const char c : value)
      if (c == '\0' || c == '\r' || c == '\n')
        return parse_fail(error, 400, "header " + std::string(name) + ": a control character in its value");
    if (out.headers.size() == limits.max_headers)
      return parse_fail(error, 431, "request head: more than " + std::to_string(limits.max_headers) + " headers");
    out.headers.emplace_back(lower(name), std::string(value));
  }
  if (out.minor_version == 1 && out.header("host") == nullptr)
    return parse_fail(error, 400, "header Host: missing (HTTP/1.1 requires it)");
  return ParseState::kDone;
}

bool body_framing(const Request& head, BodyFraming& framing, ParseError& error) {
  framing = BodyFraming{};
  const std::string* te = nullptr;
  const std::string* cl = nullptr;
  for (const auto& [name, value] : head.headers) {
    if (name == "transfer-encoding") {
      if (te != nullptr) {
        error = {400, "header Transfer-Encoding: given twice"};
        return false;
      }
      te = &value;
    } else if (name == "content-length") {
      if (cl != nullptr && *cl != value) {
        error = {400, "header Content-Length: given twice with different values"};
        return false;
      }
      cl = &value;
    }
  }
  if (te != nullptr) {
    if (cl != nullptr) {
      error = {400, "headers Transfer-Encoding and Content-Length: both given; send one"};
      return false;
    }
    if (lower(*te) != "chunked") {
      error = {501, "header Transfer-Encoding: '" + te->substr(0, 64) + "'; only \"chunked\" is accepted"};
      return false;
    }
    framing.kind = BodyFraming::Kind::kChunked;
    return true;
  }
  if (cl != nullptr) {
    if (cl->empty() || cl->size() > 19 || !std::all_of(cl->begin(), cl->end(), [](char c) { return c >= '0' && c <= '9'; })) {
      error = {400, "header Content-Length: '" + cl->substr(0, 64) + "' is not a number of bytes"};
      return false;
    }
    framing.length = std::stoull(*cl);
    framing.kind = framing.length == 0 ? BodyFraming::Kind::kNone : BodyFraming::Kind::kLength;
  }
  return true;
}

BodyReader::BodyReader(BodyFraming framing, std::size_t max_bytes)
    : framing_(framing),
      max_bytes_(max_bytes),
      step_(framing.kind == BodyFraming::Kind::kChunked ? Step::kChunkSize
            : framing.kind == BodyFraming::Kind::kLength ? Step::kLengthBody
                                                          : Step::kDone),
      left_(framing.length) {}

ParseState BodyReader::feed(std::string_view bytes, std::string& body, std::size_t& consumed, ParseError& error) {
  consumed = 0;
  const auto too_large = [&](std::uint64_t declared) {
    return parse_fail(error, 413, "request body: " + std::to_string(declared) + " bytes, more than the " +
                                std::to_string(max_bytes_) + " bytes allowed");
  };
  if (step_ == Step::kLengthBody && left_ + body.size() > max_bytes_) return too_large(left_ + body.size());
  while (step_ != Step::kDone) {
    const std::string_view rest = bytes.substr(consumed);
    switch (step_) {
      case Step::kLengthBody:
      case Step::kChunkData: {
        const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left_, rest.size()));
        body.append(rest.substr(0, n));
        consumed += n;
        left_ -= n;
        if (left_ > 0) return ParseState::kNeedMore;
        step_ = step_ == Step::kLengthBody ? Step::kDone : Step::kChunkDataEnd;
        break;
      }
      case Step::kChunkDataEnd: {
        if (rest.size() < 2) {
          if (rest == "\n") {  // a bare LF ends the chunk too
            consumed += 1;
            step_ = Step::kChunkSize;
            break;
          }
          if (!rest.empty() && rest[0] != '\r') return parse_fail(error, 400, "chunked body: no CRLF after a chunk's data");
          return ParseState::kNeedMore;
        }
        if (rest.starts_with("\r\n")) consumed += 2;
        else if (rest.starts_with("\n")) consumed += 1;
        else return parse_fail(error, 400, "chunked body: no CRLF after a chunk's data");
        step_ = Step::kChunkSize;
        break;
      }
      case Step::kChunkSize:
      case Step::kTrailer: {
        const std::size_t nl = rest.find('\n');
        if (nl == std::string_view::npos) {
          if (rest.size() > kMaxChunkLine)
            return parse_fail(error, 400, "chunked body: a chunk-size or trailer line longer than " +
                                        std::to_string(kMaxChunkLine) + " bytes");
          return ParseState::kNeedMore;
        }
        std::string_view line = rest.substr(0, nl);
        consumed += nl + 1;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (step_ == Step::kTrailer) {
          if (line.empty()) step_ = Step::kDone;  // trailers are read and ignored
          break;
        }
        const std::string_view digits = trim(line.substr(0, line.find(';')));
        std::uint64_t size = 0;
        if (digits.empty() || digits.size() > 15)
          return parse_fail(error, 400, "chunked body: a chunk size that is not 1..15 hex digits");
        for (const char c : digits) {
          const int v = hex_value(c);
          if (v < 0) return parse_fail(error, 400, "chunked body: a chunk size that is not hex");
          size = size * 16 + static_cast<std::uint64_t>(v);
        }
        if (size == 0) {
          step_ = Step::kTrailer;
          break;
        }
        // Refused on the declared size, before its data arrives.
        if (body.size() + size > max_bytes_) return too_large(body.size() + size);
        left_ = size;
        step_ = Step::kChunkData;
        break;
      }
      case Step::kDone: break;
    }
  }
  return ParseState::kDone;
}

}  // namespace hapticlab::console::http
