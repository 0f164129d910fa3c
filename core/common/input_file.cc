#include "core/common/input_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <set>
#include <vector>

#include <nlohmann/json.hpp>

namespace hapticlab {
namespace {

using nlohmann::json;

// Closes the descriptor on every path out of read_text_file.
class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }

 private:
  int fd_;
};

// Where byte `offset` of `text` sits, 1-based, as editors count.
std::string line_and_column(std::string_view text, std::size_t offset) {
  std::size_t line = 1;
  std::size_t column = 1;
  for (std::size_t i = 0; i < offset && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return "line " + std::to_string(line) + ", column " + std::to_string(column);
}

// A SAX pass over the document before the DOM is built: nlohmann's own
// parser is iterative, so this pass itself is safe at any depth, and it stops
// at the first problem. It tracks where it is so messages can say so.
class StrictChecker {
 public:
  using number_integer_t = json::number_integer_t;
  using number_unsigned_t = json::number_unsigned_t;
  using number_float_t = json::number_float_t;
  using string_t = json::string_t;
  using binary_t = json::binary_t;

  bool null() { return value(); }
  bool boolean(bool) { return value(); }
  bool number_integer(number_integer_t) { return value(); }
  bool number_unsigned(number_unsigned_t) { return value(); }
  bool number_float(number_float_t, const string_t&) { return value(); }
  bool string(string_t&) { return value(); }
  bool binary(binary_t&) { return value(); }

  bool start_object(std::size_t) { return open(true); }
  bool start_array(std::size_t) { return open(false); }
  bool end_object() { return close(); }
  bool end_array() { return close(); }

  bool key(string_t& k) {
    Frame& top = frames_.back();
    if (!top.keys.insert(k).second) {
      error_ = "key '" + k + "' appears twice in " +
               (frames_.size() == 1 ? std::string("the top-level object")
                                    : "object '" + path(frames_.size() - 1) + "'") +
               "; each key may be given once";
      return false;
    }
    top.key = k;
    return true;
  }

  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& e) {
    error_ = std::string("not valid JSON: ") + e.what();
    return false;
  }

  const std::string& error() const { return error_; }

 private:
  struct Frame {
    bool object = false;
    std::set<std::string> keys;  // object: the keys seen so far
    std::string key;             // object: the key of the current member
    std::size_t count = 0;       // array: elements started so far
  };

  // Every value (scalar, object or array) starts here.
  bool value() {
    if (!frames_.empty() && !frames_.back().object) ++frames_.back().count;
    return true;
  }

  bool open(bool object) {
    value();
    if (frames_.size() >= static_cast<std::size_t>(kMaxJsonDepth)) {
      std::string where = path(frames_.size());
      if (where.size() > 80) where = where.substr(0, 77) + "...";
      error_ = "arrays and objects are nested more than " + std::to_string(kMaxJsonDepth) +
               " levels deep (at '" + where + "'); that is the limit";
      return false;
    }
    frames_.push_back({object, {}, {}, 0});
    return true;
  }

  bool close() {
    frames_.pop_back();
    return true;
  }

  // Path of the member currently open in each of the first `levels` frames,
  // e.g. "translation.friction" or "participants[2].tasks".
  std::string path(std::size_t levels) const {
    std::string out;
    for (std::size_t i = 0; i < levels; ++i) {
      const Frame& f = frames_[i];
      if (f.object) {
        out += (out.empty() ? "" : ".") + f.key;
      } else {
        // Appended piecewise: GCC 12 at -O3 warns, wrongly, about
        // "[" + std::to_string(...) (a string inserted at its front).
        out += '[';
        out += std::to_string(f.count == 0 ? 0 : f.count - 1);
        out += ']';
      }
    }
    return out;
  }

  std::vector<Frame> frames_;
  std::string error_;
};

}  // namespace

std::string format_byte_limit(std::size_t bytes) {
  constexpr std::size_t kMiB = std::size_t{1} << 20;
  constexpr std::size_t kKiB = std::size_t{1} << 10;
  if (bytes >= kMiB && bytes % kMiB == 0) return std::to_string(bytes / kMiB) + " MiB";
  if (bytes >= kKiB && bytes % kKiB == 0) return std::to_string(bytes / kKiB) + " KiB";
  return std::to_string(bytes) + " bytes";
}

std::string read_text_file(const std::filesystem::path& path, std::size_t max_bytes,
                           std::string_view what) {
  const Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (fd.get() < 0) {
    throw InputFileError(path.string() + ": cannot open " + std::string(what) + ": " + std::strerror(errno));
  }
  // Read one byte past the limit: a file of exactly the limit is fine, and
  // an endless device stops there.
  std::string text;
  char buffer[64 * 1024];
  for (;;) {
    const std::size_t room = max_bytes + 1 - text.size();
    const ssize_t n = ::read(fd.get(), buffer, room < sizeof buffer ? room : sizeof buffer);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputFileError(path.string() + ": cannot read " + std::string(what) + ": " + std::strerror(errno));
    }
    if (n == 0) break;
    text.append(buffer, static_cast<std::size_t>(n));
    if (text.size() > max_bytes) {
      throw InputFileError(path.string() + ": larger than " + format_byte_limit(max_bytes) + ", the limit for a " +
                           std::string(what));
    }
  }
  return text;
}

json parse_json_strict(std::string_view text) {
  if (const std::size_t nul = text.find('\0'); nul != std::string_view::npos) {
    throw InputFileError("not valid JSON: NUL byte at " + line_and_column(text, nul) + " (byte " +
                         std::to_string(nul + 1) + " of " + std::to_string(text.size()) +
                         "); a JSON file cannot contain one");
  }
  StrictChecker checker;
  if (!json::sax_parse(text, &checker)) throw InputFileError(checker.error());
  try {
    return json::parse(text);
  } catch (const json::exception& e) {  // the check above already refuses what this could
    throw InputFileError(std::string("not valid JSON: ") + e.what());
  }
}

std::string visible_text(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    const std::string_view rest = s.substr(i);
    // Invisible code points that spreadsheets and editors leave in text.
    if (rest.starts_with("\xEF\xBB\xBF")) {
      out += "<U+FEFF>";
      i += 2;
    } else if (rest.starts_with("\xE2\x80\x8B")) {
      out += "<U+200B>";
      i += 2;
    } else if (rest.starts_with("\xC2\xA0")) {
      out += "<U+00A0>";
      i += 1;
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c == '\n') {
      out += "\\n";
    } else if (c < 0x20 || c == 0x7F) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += hex;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out;
}

}  // namespace hapticlab
