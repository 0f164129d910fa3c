#pragma once
// One client connection of the console's server and the states it goes
// through (the event loop in http_server.cc drives it):
//
//   head ──(head read, Host and route and admit checked)──► body
//   body ──(body read)──► waiting (a worker runs the route) ──► writing
//        └──────────────(a route of the loop)───────────────► writing
//        └──────────────(an event stream)───────────────────► streaming
//   writing ──(sent; keep-alive)──► head        otherwise: closed
//
// Each state has a deadline: an idle keep-alive connection, a head or a
// body that trickles in, a client that stops reading an answer are all
// closed when theirs passes. The buffers are bounded: the head by the
// parser's limit, a file's answer is read 64 kB at a time as the socket
// takes it, and a stream whose client stops reading is closed once its
// backlog passes the server's bound.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "console/http/http_request.h"

namespace hapticlab::console::http {

struct Route;

using Clock = std::chrono::steady_clock;

struct Connection {
  enum class State : std::uint8_t { kHead, kBody, kWaiting, kWriting, kStreaming };

  Connection(int fd_in, std::uint64_t id_in, std::size_t site_in, Clock::time_point now)
      : fd(fd_in), id(id_in), site(site_in), state_since(now), deadline(now) {}
  ~Connection();  // closes fd and a file being sent
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  // No request in progress: between keep-alive requests, nothing received.
  bool idle() const noexcept { return state == State::kHead && in.empty(); }
  // May be dropped to make room for another connection: idle, or still
  // sending its head (a slow or stalled client).
  bool evictable() const noexcept { return state == State::kHead; }
  std::size_t unsent() const noexcept { return out.size() - out_sent; }
  // Appends to what is to be sent.
  void queue(const std::string& bytes);
  // Enters `s` with `deadline_after` from now as its deadline.
  void enter(State s, Clock::time_point now, std::chrono::milliseconds deadline_after);
  // Writes what it can without blocking, refilling from the file. False when
  // the connection failed (reset, closed by the client).
  bool flush();
  // Everything is sent (the file included).
  bool sent_all() const noexcept { return unsent() == 0 && file_left == 0; }

  const int fd;
  const std::uint64_t id;     // unique for the server's lifetime (fds are reused)
  const std::size_t site;     // which listener accepted it
  State state = State::kHead;
  Clock::time_point state_since;
  Clock::time_point deadline;
  std::uint32_t epoll_mask = 0;
  bool in_epoll = false;

  std::string in;  // received, not parsed yet
  std::string out;
  std::size_t out_sent = 0;
  int file_fd = -1;             // a file answer being sent
  std::uint64_t file_left = 0;  // its bytes not yet read into `out`
  bool progressed = false;      // flush() sent something

  Request request;
  std::optional<BodyReader> body;
  const Route* route = nullptr;
  bool keep_alive = true;  // after this answer
};

}  // namespace hapticlab::console::http
