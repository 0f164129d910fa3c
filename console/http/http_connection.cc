#include "console/http/http_connection.h"

#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>

namespace hapticlab::console::http {
namespace {

constexpr std::size_t kFilePiece = 64 * 1024;  // read from a file as the socket takes it

}  // namespace

Connection::~Connection() {
  if (file_fd >= 0) ::close(file_fd);
  ::close(fd);
}

void Connection::queue(const std::string& bytes) {
  // Drop what was sent before appending, so `out` stays as small as the backlog.
  if (out_sent > 0 && out_sent == out.size()) {
    out.clear();
    out_sent = 0;
  } else if (out_sent > kFilePiece) {
    out.erase(0, out_sent);
    out_sent = 0;
  }
  out += bytes;
}

void Connection::enter(State s, Clock::time_point now, std::chrono::milliseconds deadline_after) {
  state = s;
  state_since = now;
  deadline = now + deadline_after;
}

int Connection::eviction_rank() const noexcept {
  switch (state) {
    case State::kHead: return 0;
    case State::kBody: return 1;
    case State::kWriting: return 2;
    case State::kStreaming: return 3;
    case State::kWaiting: return -1;
  }
  return -1;
}

bool Connection::flush(std::size_t budget_bytes) {
  std::size_t sent = 0;
  while (sent < budget_bytes) {
    if (unsent() == 0) {
      out.clear();
      out_sent = 0;
      if (file_left == 0) return true;
      std::array<char, kFilePiece> piece;
      const ssize_t n = ::read(file_fd, piece.data(), std::min<std::uint64_t>(file_left, piece.size()));
      if (n <= 0) return false;  // the file was cut short while sent: end the answer, which is then short
      out.assign(piece.data(), static_cast<std::size_t>(n));
      file_left -= static_cast<std::uint64_t>(n);
    }
    const ssize_t n = ::send(fd, out.data() + out_sent, std::min(unsent(), budget_bytes - sent), MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) return true;
      if (errno == EINTR) continue;
      return false;
    }
    out_sent += static_cast<std::size_t>(n);
    sent += static_cast<std::size_t>(n);
  }
  return true;  // the budget is spent; the socket is still writable, so the loop comes back
}

}  // namespace hapticlab::console::http
