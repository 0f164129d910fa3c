// How the console's HTTP server admits connections: accepting them under
// its limits on descriptors and per-site slots, and evicting one to make room.
#include "console/http/http_server.h"

#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <memory>

namespace hapticlab::console::http {
namespace {

constexpr int kAcceptsPerRound = 64;    // per site and round of the loop
constexpr int kSendBuffer = 64 * 1024;  // SO_SNDBUF of a connection (the kernel doubles it)

}  // namespace

void Server::accept_all(std::size_t site) {
  Listener& l = *listeners_[site];
  // Bounded per round: a flood of connections does not keep the loop from
  // the requests it already has (the rest wait in the listen backlog).
  for (int accepted = 0; accepted < kAcceptsPerRound; ++accepted) {
    const int fd = ::accept4(l.fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if ((errno == EMFILE || errno == ENFILE) && evict_one(site)) continue;
      if ((errno == EMFILE || errno == ENFILE) && spare_fd_ >= 0) {
        // Out of descriptors with nothing to drop: take the connection and
        // close it, rather than leave it to make the listener ready for ever.
        ::close(spare_fd_);
        const int refused = ::accept4(l.fd, nullptr, nullptr, SOCK_CLOEXEC);
        if (refused >= 0) ::close(refused);
        spare_fd_ = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
      }
      return;  // EAGAIN: none left
    }
    if (l.connections >= l.site.max_connections && !evict_one(site)) {
      ::close(fd);  // every slot of this site has a request a worker holds
      continue;
    }
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    // A fixed send buffer (the kernel's own would grow to megabytes for a
    // client that does not read): what an answer has "sent" is near what
    // the client took, so its deadline means something, and one client
    // pins little of the kernel's memory.
    ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &kSendBuffer, sizeof kSendBuffer);
    const Clock::time_point now = Clock::now();
    auto c = std::make_unique<Connection>(fd, next_id_++, site, now);
    c->enter(Connection::State::kHead, now, config_.idle_timeout);
    fd_of_[c->id] = fd;
    Connection& ref = *c;
    connections_[fd] = std::move(c);
    ++l.connections;
    set_mask(ref, EPOLLIN);
  }
}

bool Server::evict_one(std::size_t site) {
  // Of this site only (another site's clients never cost it a slot): the
  // idle and the slow first, then the answer longest in the sending (a
  // client that does not read), then the oldest stream. STOP, sent now,
  // gets the slot.
  Connection* victim = nullptr;
  for (const auto& [fd, c] : connections_) {
    if (c->site != site || c->eviction_rank() < 0) continue;
    if (victim == nullptr || c->eviction_rank() < victim->eviction_rank() ||
        (c->eviction_rank() == victim->eviction_rank() && c->state_since < victim->state_since))
      victim = c.get();
  }
  if (victim == nullptr) return false;
  close(*victim, true);
  return true;
}

}  // namespace hapticlab::console::http
