#include "console/http/http_server.h"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <exception>
#include <stdexcept>

namespace hapticlab::console::http {
namespace {

constexpr std::size_t kReadPiece = 16 * 1024;
constexpr std::size_t kWriteBudget = 256 * 1024;  // bytes sent to one connection per readiness event
constexpr auto kDeadlineScan = std::chrono::milliseconds(50);
// A worker's answer has no deadline of its own (the route's work bounds
// it); this one only frees the slot of a client that would wait for ever.
constexpr auto kWaitingLimit = std::chrono::minutes(5);

std::string errno_text() { return std::strerror(errno); }

std::string as_ms(std::chrono::milliseconds d) { return std::to_string(d.count()) + " ms"; }

std::string sse_head(const std::vector<std::pair<std::string, std::string>>& defaults) {
  Response r;
  r.content_type = "text/event-stream; charset=utf-8";
  return response_head(r, std::nullopt, false, defaults);
}

}  // namespace

Server::Server(ServerConfig config) : config_(std::move(config)) {
  headers_ = config_.default_headers;
  epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  spare_fd_ = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  if (epoll_fd_ < 0 || wake_fd_ < 0) throw std::runtime_error("console server: cannot create its event loop: " + errno_text());
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = 0;  // 0: the wake-up; 1..n: a listener; else a connection's id + n
  ::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, wake_fd_, &ev);
  control_ = std::make_unique<WorkQueue>("control", 1, 64);
  reader_ = std::make_unique<WorkQueue>("reader", 2, 64);
  urgent_ = std::make_unique<WorkQueue>("urgent", 1, 64);
}

Server::~Server() {
  control_.reset();  // their last tasks post to done_: before anything else goes
  reader_.reset();
  urgent_.reset();
  connections_.clear();
  for (const auto& l : listeners_) ::close(l->fd);
  if (spare_fd_ >= 0) ::close(spare_fd_);
  ::close(wake_fd_);
  ::close(epoll_fd_);
}

int Server::add_site(Site site) {
  if (site.max_connections == 0) throw std::invalid_argument("console (" + site.name + "): max_connections must be >= 1");
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string where = site.bind_address + ":" + std::to_string(site.port);
  if (::getaddrinfo(site.bind_address.c_str(), std::to_string(site.port).c_str(), &hints, &found) != 0 || !found)
    throw std::runtime_error("console (" + site.name + "): cannot listen on " + where + ": not an address");
  int fd = -1;
  std::string why;
  for (addrinfo* a = found; a != nullptr && fd < 0; a = a->ai_next) {
    fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) continue;
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) != 0 || ::listen(fd, 1024) != 0) {
      why = errno_text();
      ::close(fd);
      fd = -1;
    }
  }
  ::freeaddrinfo(found);
  if (fd < 0)
    throw std::runtime_error("console (" + site.name + "): cannot listen on " + where + " (" + why +
                             "; in use, or not an address of this machine)");
  sockaddr_storage bound{};
  socklen_t len = sizeof bound;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &len);
  const int port = ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port
                                                     : reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
  listeners_.push_back(std::make_unique<Listener>(Listener{fd, HostCheck(site.bind_address, port), std::move(site)}));
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = listeners_.size();
  ::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &ev);
  return port;
}

void Server::add_channel(const std::string& name, std::function<std::string()> on_join) {
  hub_.add_channel(name, std::move(on_join));
}

void Server::every(std::chrono::milliseconds period, std::function<void()> fn) {
  timers_.push_back({period, Clock::now() + period, std::move(fn)});
}

void Server::publish(const std::string& channel, const std::string& event) {
  // Copied: closing a slow subscriber changes the set.
  const std::set<std::uint64_t> ids = hub_.subscribers(channel);
  for (const std::uint64_t id : ids) {
    Connection* c = find(id);
    if (c == nullptr) continue;
    if (c->unsent() > config_.max_stream_backlog_bytes) {
      close(*c, true);  // it stopped reading: its backlog would only grow
      continue;
    }
    const bool was_empty = c->unsent() == 0;
    c->queue(event);
    // The backlog's deadline starts with its first unsent event and is not
    // moved while it drains: it must be empty by then.
    if (was_empty) c->deadline = Clock::now() + config_.write_timeout;
    writable(*c);
  }
}

Connection* Server::find(std::uint64_t id) {
  const auto it = fd_of_.find(id);
  if (it == fd_of_.end()) return nullptr;
  return connections_.at(it->second).get();
}

void Server::run(const std::atomic<bool>& stop) {
  std::array<epoll_event, 256> events;
  Clock::time_point next_scan = Clock::now() + kDeadlineScan;
  const std::uint64_t listener_ids = listeners_.size();
  while (!stop.load()) {
    Clock::time_point wake = next_scan;
    for (const Timer& t : timers_) wake = std::min(wake, t.next);
    for (const std::uint64_t id : bounded_waits_)
      if (const Connection* c = find(id)) wake = std::min(wake, c->deadline);
    if (!ready_.empty()) wake = Clock::now();  // pipelined requests wait: only look for events
    const auto wait_ms = std::chrono::ceil<std::chrono::milliseconds>(wake - Clock::now()).count();
    const int n = ::epoll_wait(epoll_fd_, events.data(), static_cast<int>(events.size()),
                               static_cast<int>(std::clamp<long long>(wait_ms, 0, 50)));
    for (int i = 0; i < n; ++i) {
      const std::uint64_t key = events[static_cast<std::size_t>(i)].data.u64;
      const std::uint32_t what = events[static_cast<std::size_t>(i)].events;
      if (key == 0) {
        take_done();
        continue;
      }
      if (key <= listener_ids) {
        accept_all(static_cast<std::size_t>(key - 1));
        continue;
      }
      Connection* c = find(key - listener_ids);
      if (c == nullptr) continue;  // closed by an earlier event of this round
      if (what & (EPOLLERR | EPOLLHUP)) {
        close(*c);
        continue;
      }
      if (what & EPOLLIN) readable(*c);
      if ((c = find(key - listener_ids)) != nullptr && (what & EPOLLOUT)) writable(*c);
    }
    serve_ready();
    const Clock::time_point now = Clock::now();
    answer_late_waits(now);
    for (Timer& t : timers_) {
      if (now < t.next) continue;
      t.next = std::max(t.next + t.period, now);
      t.fn();
    }
    if (now >= next_scan) {
      check_deadlines(now);
      next_scan = now + kDeadlineScan;
    }
  }
}

void Server::set_mask(Connection& c, std::uint32_t mask) {
  if (c.in_epoll && c.epoll_mask == mask) return;
  epoll_event ev{};
  ev.events = mask;
  ev.data.u64 = c.id + listeners_.size();
  ::epoll_ctl(epoll_fd_, c.in_epoll ? EPOLL_CTL_MOD : EPOLL_CTL_ADD, c.fd, &ev);
  c.in_epoll = true;
  c.epoll_mask = mask;
}

void Server::close(Connection& c, bool reset) {
  if (reset) {
    const linger abortive{1, 0};
    ::setsockopt(c.fd, SOL_SOCKET, SO_LINGER, &abortive, sizeof abortive);
  }
  Listener& l = *listeners_[c.site];
  if (c.state == Connection::State::kStreaming) --l.streams;
  --l.connections;
  hub_.unsubscribe(c.id);
  fd_of_.erase(c.id);
  connections_.erase(c.fd);  // closes the socket, which leaves the epoll set
}

void Server::readable(Connection& c) {
  std::array<char, kReadPiece> buffer;
  const ssize_t n = ::recv(c.fd, buffer.data(), buffer.size(), 0);
  if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
    close(c);  // the client closed (or reset) its side
    return;
  }
  if (n < 0) return;
  if (c.state == Connection::State::kStreaming) return;  // a stream's client has nothing to say
  const Clock::time_point now = Clock::now();
  if (c.idle()) c.enter(Connection::State::kHead, now, config_.head_timeout);  // its first byte starts the head's deadline
  c.in.append(buffer.data(), static_cast<std::size_t>(n));
  process(c);
}

void Server::process(Connection& c) {
  const std::uint64_t id = c.id;
  ParseError error;
  while (find(id) != nullptr) {
    if (c.state == Connection::State::kHead) {
      if (c.in.empty()) return;
      std::size_t consumed = 0;
      const ParseState s = parse_head(c.in, config_.limits, c.request, consumed, error);
      if (s == ParseState::kNeedMore) return;
      if (s == ParseState::kError) {
        c.keep_alive = false;
        respond(c, Response::error(error.status, error.message));
        return;
      }
      c.in.erase(0, consumed);
      head_done(c);
      continue;
    }
    if (c.state == Connection::State::kBody) {
      std::size_t consumed = 0;
      const ParseState s = c.body->feed(c.in, c.request.body, consumed, error);
      c.in.erase(0, consumed);
      if (s == ParseState::kNeedMore) return;
      if (s == ParseState::kError) {
        c.keep_alive = false;
        respond(c, Response::error(error.status, error.message));
        return;
      }
      dispatch(c);
      return;
    }
    return;  // waiting, writing, streaming: the rest of `in` is the next request's
  }
}

const Route* Server::match(const Site& site, const Request& r, bool& path_known) const {
  path_known = false;
  for (const Route& route : site.routes) {
    const bool hit = route.prefix ? r.path.starts_with(route.path) && r.path.size() > route.path.size()
                                  : r.path == route.path;
    if (!hit) continue;
    path_known = true;
    if (route.method == r.method) return &route;
  }
  return nullptr;
}

void Server::head_done(Connection& c) {
  const Listener& l = *listeners_[c.site];
  Request& r = c.request;
  c.keep_alive = r.keep_alive();
  BodyFraming framing;
  ParseError error;
  const bool framed = body_framing(r, framing, error);
  // Answered without reading a body: the connection cannot be reused.
  const auto refuse = [&](Response response) {
    if (framing.kind != BodyFraming::Kind::kNone || !framed) c.keep_alive = false;
    respond(c, std::move(response));
  };
  const std::string* host = r.header("host");  // parse_head required it of HTTP/1.1, not of 1.0
  if (host == nullptr || !l.hosts.allowed(*host)) {
    refuse(Response::error(421, "Host '" + (host ? host->substr(0, 200) : std::string()) + "': this console (" +
                                    l.site.name + ") answers only requests for " + l.hosts.describe() +
                                    " (a guard against DNS rebinding); open it by that address"));
    return;
  }
  if (!framed) {
    refuse(Response::error(error.status, error.message));
    return;
  }
  bool path_known = false;
  const Route* route = match(l.site, r, path_known);
  if (route == nullptr) {
    Response res = path_known ? Response::error(405, r.method + " " + r.path + ": method not allowed here")
                              : Response::error(404, "no such page: " + r.path.substr(0, 200));
    refuse(std::move(res));
    return;
  }
  if (route->admit) {
    std::optional<Response> refusal;
    try {
      refusal = route->admit(r);
    } catch (const std::exception& e) {
      refusal = Response::error(500, e.what());
    }
    if (refusal) {
      refuse(std::move(*refusal));
      return;
    }
  }
  if (framing.kind == BodyFraming::Kind::kLength && framing.length > route->max_body_bytes) {
    refuse(Response::error(413, "request body: Content-Length " + std::to_string(framing.length) + " bytes, more than the " +
                                    std::to_string(route->max_body_bytes) + " bytes " + r.method + " " + r.path +
                                    " accepts"));
    return;
  }
  c.route = route;
  c.body.emplace(framing, route->max_body_bytes);
  c.enter(Connection::State::kBody, Clock::now(), config_.body_timeout);
  // curl asks before sending a body over 1 kB; without an answer it waits a second.
  if (const std::string* expect = r.header("expect");
      expect != nullptr && *expect == "100-continue" && framing.kind != BodyFraming::Kind::kNone && c.in.empty()) {
    c.queue("HTTP/1.1 100 Continue\r\n\r\n");
    if (!c.flush(kWriteBudget)) close(c);
  }
}

void Server::dispatch(Connection& c) {
  const Route& route = *c.route;
  const Clock::time_point now = Clock::now();
  if (!route.stream.empty()) {
    Listener& l = *listeners_[c.site];
    if (l.streams >= l.site.max_streams) {
      c.keep_alive = false;
      respond(c, Response::error(503, "event stream refused: " + std::to_string(l.site.max_streams) +
                                          " streams are open on the " + l.site.name +
                                          "'s port, the most it serves; close a console tab or participant screen"));
      return;
    }
    hub_.subscribe(route.stream, c.id);
    ++l.streams;
    c.keep_alive = false;
    c.enter(Connection::State::kStreaming, now, config_.write_timeout);
    c.queue(sse_head(headers_) + hub_.join_event(route.stream));
    set_mask(c, EPOLLIN);
    writable(c);
    return;
  }
  if (route.runs == Runs::kLoop) {
    Response r;
    try {
      r = route.handle(c.request);
    } catch (const std::exception& e) {
      r = Response::error(500, e.what());
    }
    respond(c, std::move(r));
    return;
  }
  WorkQueue& queue = route.runs == Runs::kControl ? *control_ : route.runs == Runs::kUrgent ? *urgent_ : *reader_;
  const std::uint64_t id = c.id;
  const std::uint64_t seq = ++c.request_seq;
  const bool posted = queue.post([this, id, seq, &route, request = c.request] {
    Response r;
    try {
      r = route.handle(request);
    } catch (const std::exception& e) {
      r = Response::error(500, e.what());
    }
    {
      std::lock_guard lock(done_mutex_);
      done_.push_back({id, seq, std::move(r)});
    }
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t w = ::write(wake_fd_, &one, sizeof one);
  });
  const bool bounded = route.answer_within.count() > 0 && route.answer_late;
  if (!posted) {
    if (bounded) {
      respond(c, route.answer_late(c.request));  // what it can say without the worker
      return;
    }
    respond(c, Response::error(503, "the console's " + queue.name() + " queue is full (" +
                                        std::to_string(queue.capacity()) + " requests wait); try again"));
    return;
  }
  c.enter(Connection::State::kWaiting, now,
          bounded ? route.answer_within : std::chrono::duration_cast<std::chrono::milliseconds>(kWaitingLimit));
  if (bounded) bounded_waits_.push_back(c.id);
  set_mask(c, 0);
}

void Server::answer_late_waits(Clock::time_point now) {
  std::vector<std::uint64_t> still;
  const std::vector<std::uint64_t> waits = std::move(bounded_waits_);
  bounded_waits_.clear();
  for (const std::uint64_t id : waits) {
    Connection* c = find(id);
    if (c == nullptr || c->state != Connection::State::kWaiting) continue;  // answered, or gone
    if (now < c->deadline) {
      still.push_back(id);
      continue;
    }
    Response r;
    try {
      r = c->route->answer_late(c->request);
    } catch (const std::exception& e) {
      r = Response::error(500, e.what());
    }
    respond(*c, std::move(r));
  }
  bounded_waits_.insert(bounded_waits_.end(), still.begin(), still.end());
}

void Server::take_done() {
  std::uint64_t count = 0;
  [[maybe_unused]] const ssize_t n = ::read(wake_fd_, &count, sizeof count);
  std::vector<Done> done;
  {
    std::lock_guard lock(done_mutex_);
    done.swap(done_);
  }
  for (Done& d : done)
    if (Connection* c = find(d.id);
        c != nullptr && c->state == Connection::State::kWaiting && c->request_seq == d.request_seq)
      respond(*c, std::move(d.response));
}

void Server::respond(Connection& c, Response r) {
  if (r.close) c.keep_alive = false;
  std::optional<std::size_t> length = r.body.size();
  if (r.file) {
    const int fd = ::open(r.file->c_str(), O_RDONLY | O_CLOEXEC);
    struct stat st {};
    if (fd < 0 || ::fstat(fd, &st) != 0) {
      if (fd >= 0) ::close(fd);
      r = Response::error(404, "cannot read " + r.file->filename().string());
    } else {
      c.file_fd = fd;
      c.file_left = static_cast<std::uint64_t>(st.st_size);
      length = static_cast<std::size_t>(st.st_size);
      r.body.clear();
    }
  }
  c.queue(response_head(r, length, c.keep_alive, headers_));
  c.queue(r.body);
  // Absolute: sent in full by then, however the client reads.
  const std::uint64_t bytes = c.unsent() + c.file_left;
  const auto allowed = config_.write_timeout + std::chrono::milliseconds(1000 * bytes / config_.min_write_rate_bytes_per_s);
  c.enter(Connection::State::kWriting, Clock::now(), allowed);
  set_mask(c, EPOLLOUT);
  writable(c);
}

void Server::writable(Connection& c) {
  if (!c.flush(kWriteBudget)) {
    close(c);
    return;
  }
  if (c.state == Connection::State::kStreaming) {
    set_mask(c, c.unsent() > 0 ? EPOLLIN | EPOLLOUT : EPOLLIN);
    return;
  }
  if (c.state == Connection::State::kWriting && c.sent_all()) finish_write(c);
}

void Server::finish_write(Connection& c) {
  if (c.file_fd >= 0) {
    ::close(c.file_fd);
    c.file_fd = -1;
  }
  if (!c.keep_alive) {
    close(c);
    return;
  }
  c.request = Request{};
  c.body.reset();
  c.route = nullptr;
  c.keep_alive = true;
  c.enter(Connection::State::kHead, Clock::now(), c.in.empty() ? config_.idle_timeout : config_.head_timeout);
  if (c.in.empty()) {
    set_mask(c, EPOLLIN);
    return;
  }
  // A request sent behind the last one (pipelined): served on the next
  // round, after every other connection's turn, and nothing more is read
  // from this client until then.
  set_mask(c, 0);
  c.ready = true;
  ready_.push_back(c.id);
}

void Server::serve_ready() {
  const std::vector<std::uint64_t> ready = std::move(ready_);
  ready_.clear();
  for (const std::uint64_t id : ready) {
    Connection* c = find(id);
    if (c == nullptr || !c->ready) continue;
    c->ready = false;
    if (c->state != Connection::State::kHead) continue;
    set_mask(*c, EPOLLIN);  // also for the rest of a head only partly received
    process(*c);
  }
}

void Server::check_deadlines(Clock::time_point now) {
  std::vector<Connection*> late;
  for (const auto& [fd, c] : connections_) {
    if (now < c->deadline) continue;
    // Its deadline is when the loop answers in the worker's place (answer_late_waits).
    if (c->state == Connection::State::kWaiting && c->route->answer_within.count() > 0 && c->route->answer_late)
      continue;
    if (c->state == Connection::State::kStreaming && c->unsent() == 0) {
      c->deadline = now + config_.write_timeout;  // a stream with nothing to send is not late
      continue;
    }
    late.push_back(c.get());
  }
  for (Connection* c : late) {
    if (c->state == Connection::State::kHead && !c->idle()) {
      // Said once, without waiting for the client to read it.
      Response r = Response::error(408, "request head: not complete within " + as_ms(config_.head_timeout));
      const std::string bytes = response_head(r, r.body.size(), false, headers_) + r.body;
      [[maybe_unused]] const ssize_t n = ::send(c->fd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    } else if (c->state == Connection::State::kBody) {
      Response r = Response::error(408, "request body: not complete within " + as_ms(config_.body_timeout));
      const std::string bytes = response_head(r, r.body.size(), false, headers_) + r.body;
      [[maybe_unused]] const ssize_t n = ::send(c->fd, bytes.data(), bytes.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    }
    // An answer or a stream not taken in time: reset, so what waits in the
    // kernel's buffers for that client is dropped now, not sent on.
    close(*c, c->state == Connection::State::kWriting || c->state == Connection::State::kStreaming);
  }
}

}  // namespace hapticlab::console::http
