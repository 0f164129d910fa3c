#include "core/common/secret_file.h"

#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <set>
#include <stdexcept>

namespace hapticlab {
namespace {

constexpr std::size_t kMaxSecretFileBytes = 4096;

std::string octal_mode(mode_t mode) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "%04o", static_cast<unsigned>(mode & 07777));
  return buf;
}

bool is_hex(char c) {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}

}  // namespace

std::string read_secret_file(const std::filesystem::path& path, const std::string& what, const SecretRules& rules) {
  const std::string where = what + ": " + path.string();
  // O_NOFOLLOW is not used: a symlink to a 0600 file is a fine way to share
  // one key; the mode checked is the file's own (fstat after open).
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::invalid_argument(where + ": cannot open it (" + std::strerror(errno) + ")");
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw std::invalid_argument(where + ": not a regular file");
  }
  if ((st.st_mode & 077) != 0) {
    ::close(fd);
    throw std::invalid_argument(where + " is open to other users (mode " + octal_mode(st.st_mode) +
                                "); chmod 600 it");
  }
  std::string text;
  char buf[1024];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    text.append(buf, static_cast<std::size_t>(n));
    if (text.size() > kMaxSecretFileBytes) break;
  }
  ::close(fd);
  if (text.size() > kMaxSecretFileBytes)
    throw std::invalid_argument(where + ": longer than " + std::to_string(kMaxSecretFileBytes) +
                                " bytes; it must hold the secret on one line");
  if (text.ends_with("\r\n")) text.resize(text.size() - 2);
  else if (text.ends_with("\n")) text.resize(text.size() - 1);
  if (text.find('\n') != std::string::npos)
    throw std::invalid_argument(where + ": holds more than one line; it must hold the secret on one line");
  for (std::size_t i = 0; i < text.size(); ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c <= 0x20 || c == 0x7f)
      throw std::invalid_argument(where + ": character " + std::to_string(i + 1) + " is " +
                                  (c == ' ' ? std::string("a space") : "control character " + std::to_string(c)) +
                                  "; a secret is printable characters without spaces");
    if (rules.hex_only && !is_hex(text[i]))
      throw std::invalid_argument(where + ": character " + std::to_string(i + 1) + " ('" + text[i] +
                                  "') is not a hex digit; the key is hex (e.g. `openssl rand -hex 32`)");
  }
  if (text.size() < rules.min_chars)
    throw std::invalid_argument(where + " holds " + std::to_string(text.size()) + " characters, must be at least " +
                                std::to_string(rules.min_chars));
  const std::set<char> distinct(text.begin(), text.end());
  if (distinct.size() < rules.min_distinct)
    throw std::invalid_argument(where + " uses only " + std::to_string(distinct.size()) +
                                " different characters, must be at least " + std::to_string(rules.min_distinct) +
                                "; make a random one (e.g. `openssl rand -hex 32`, or `hapticlab device keygen`)");
  return text;
}

std::string random_hex(std::size_t bytes) {
  std::string raw(bytes, '\0');
  std::size_t got = 0;
  while (got < bytes) {
    const ssize_t n = ::getrandom(raw.data() + got, bytes - got, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error(std::string("getrandom: ") + std::strerror(errno));
    got += static_cast<std::size_t>(n);
  }
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(2 * bytes);
  for (char c : raw) {
    const auto b = static_cast<unsigned char>(c);
    out += kDigits[b >> 4];
    out += kDigits[b & 15];
  }
  return out;
}

void create_secret_file(const std::filesystem::path& path, const std::string& secret) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error(path.string() + ": cannot create it (" + std::strerror(errno) + ")");
  const std::string line = secret + "\n";
  const ssize_t n = ::write(fd, line.data(), line.size());
  const bool synced = ::fsync(fd) == 0;
  ::close(fd);
  if (n != static_cast<ssize_t>(line.size()) || !synced) {
    ::unlink(path.c_str());
    throw std::runtime_error(path.string() + ": cannot write it (" + std::strerror(errno) + ")");
  }
}

std::string hex_bytes(const std::string& hex) {
  if (hex.size() % 2 != 0)
    throw std::invalid_argument("hex: " + std::to_string(hex.size()) + " digits, must be an even number");
  std::string out;
  out.reserve(hex.size() / 2);
  const auto value = [&](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    throw std::invalid_argument(std::string("hex: '") + c + "' is not a hex digit");
  };
  for (std::size_t i = 0; i < hex.size(); i += 2)
    out += static_cast<char>(value(hex[i]) * 16 + value(hex[i + 1]));
  return out;
}

}  // namespace hapticlab
