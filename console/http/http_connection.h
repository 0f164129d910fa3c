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
// body that trickles in, an answer not sent in full within its time (not
// renewed as bytes go: a client that reads a byte now and then cannot keep
// an answer open), a stream backlog not drained in time, are all closed when
// theirs passes. The buffers are bounded: the head by the parser's limit, a
// file's answer is read 64 kB at a time as the socket takes it, and a
// stream whose client stops reading is closed once its backlog passes the
// server's bound.

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
  // Which connections are dropped first when a site's table is full (lower
  // first; among equals the one longest in its state): idle or still
  // sending its head, then sending a body, then being sent an answer, then
  // a stream. -1: never (a worker holds its request; the work queues bound
  // how many can).
  int eviction_rank() const noexcept;
  std::size_t unsent() const noexcept { return out.size() - out_sent; }
  // Appends to what is to be sent.
  void queue(const std::string& bytes);
  // Enters `s` with `deadline_after` from now as its deadline.
  void enter(State s, Clock::time_point now, std::chrono::milliseconds deadline_after);
  // Writes what it can without blocking, at most `budget_bytes` (one
  // client's large answer does not hold the loop), refilling from the file.
  // False when the connection failed (reset, closed by the client).
  bool flush(std::size_t budget_bytes);
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
  bool ready = false;  // holds a pipelined request, served on a later round of the loop

  std::string in;  // received, not parsed yet
  std::string out;
  std::size_t out_sent = 0;
  int file_fd = -1;             // a file answer being sent
  std::uint64_t file_left = 0;  // its bytes not yet read into `out`

  Request request;
  std::optional<BodyReader> body;
  const Route* route = nullptr;
  bool keep_alive = true;  // after this answer
  // Counts the requests handed to a worker: a worker's answer is taken
  // only by the request it was for (not by a later one of the connection
  // when the first was answered without it, past its route's bound).
  std::uint64_t request_seq = 0;
};

}  // namespace hapticlab::console::http
