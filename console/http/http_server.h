#pragma once
// The console's HTTP/1.1 server: one event loop thread (epoll) serves every
// connection of every site (the operator's port, the participant's port),
// so no number of open connections, streams or slow clients can keep it
// from answering STOP. Routes that answer from memory run on the loop;
// routes that may take long (a control that writes the study database, a
// read of the whole study) run on a worker thread while the loop goes on.
// Event streams are fanned out from the loop (stream_hub.h); files are sent
// from the loop 64 kB at a time.
//
// Fairness: each readiness event of a connection serves at most one
// request (requests pipelined behind it wait for a later round of the
// loop, after every other ready connection had its turn) and sends at most
// 256 kB; a round accepts at most 64 new connections per site.
//
// Limits (docs/console.md, "Limits"): a request head of 16 kB and 64
// headers, a body of the route's cap (chunked or not), deadlines for an idle
// connection, a head, a body, and for sending an answer in full (absolute:
// not renewed as bytes go), and per site a cap on connections and on
// streams: one site's clients never take another's slots. A new connection
// past its site's cap drops one of that site's (idle or slow first, then the
// oldest answer being sent, then the oldest stream), never a request a
// worker holds.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "console/http/host_check.h"
#include "console/http/http_connection.h"
#include "console/http/http_request.h"
#include "console/http/http_response.h"
#include "console/http/stream_hub.h"
#include "console/http/work_queue.h"

namespace hapticlab::console::http {

// Where a route's handler runs.
enum class Runs : std::uint8_t {
  kLoop,     // on the event loop: answers from memory only, in well under a millisecond
  kControl,  // on the one control thread, in the order received (controls never race each other)
  kReader,   // on a reader thread (two): reads of the database or the disk
  kUrgent,   // on the urgent thread (one), never behind a control or a read: STOP's record
};

struct Route {
  std::string method;  // "GET", "POST"
  std::string path;    // exact; with `prefix`, every path that starts with it
  bool prefix = false;
  std::size_t max_body_bytes = 0;  // a longer body is refused (413) before it is read
  // On the loop thread as soon as the head is in, before any byte of the
  // body is read (a token check): a response here is the answer, and the
  // body is never read. It may note something for `handle` in
  // Request::admitted. May be null.
  std::function<std::optional<Response>(Request&)> admit;
  Runs runs = Runs::kLoop;
  std::function<Response(const Request&)> handle;
  std::string stream;  // not empty: an event stream of this channel (`handle` unused)
  // > 0 with `answer_late`: when the worker has not answered within this
  // time of the request's dispatch, the loop answers `answer_late(request)`
  // in its place (and the worker's answer, when it comes, is dropped). The
  // handler runs on all the same.
  std::chrono::milliseconds answer_within{0};
  std::function<Response(const Request&)> answer_late;
};

struct Site {
  std::string name;          // "operator", "participant": for messages
  std::string bind_address;  // as --bind
  int port = 0;              // 0: any free one
  std::vector<Route> routes;
  std::size_t max_connections = 256;  // open at once on this site's port (>= 1)
  std::size_t max_streams = 32;       // event streams at once on this site (past it: 503 naming the cap)
};

struct ServerConfig {
  Limits limits;
  std::chrono::milliseconds idle_timeout{15000};   // keep-alive, no request begun
  std::chrono::milliseconds head_timeout{5000};    // from a request's first byte to the end of its head
  std::chrono::milliseconds body_timeout{5000};    // from the end of the head to the end of the body
  // An answer must be sent in full within write_timeout plus its size at
  // min_write_rate (absolute, from when it is ready: a client that reads a
  // byte now and then cannot hold it longer); a stream's backlog must be
  // drained within write_timeout of its first unsent event.
  std::chrono::milliseconds write_timeout{10000};
  std::uint64_t min_write_rate_bytes_per_s = 1u << 20;
  std::size_t max_stream_backlog_bytes = 1u << 20;  // a stream's unsent events; past it the stream is closed
  // Headers of every response unless it sets its own (security headers, Cache-Control).
  std::vector<std::pair<std::string, std::string>> default_headers;
};

class Server {
 public:
  explicit Server(ServerConfig config);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Listens for `site`; returns the port. Throws std::runtime_error naming
  // the address when it cannot (in use, not an address of this machine).
  int add_site(Site site);
  // A stream channel (stream_hub.h); before run().
  void add_channel(const std::string& name, std::function<std::string()> on_join);
  // `fn` on the loop thread every `period`, from run() on.
  void every(std::chrono::milliseconds period, std::function<void()> fn);
  // On the loop thread (from an `every`): `event` ("data: ...\n\n") to
  // every subscriber of `channel`.
  void publish(const std::string& channel, const std::string& event);
  bool has_subscribers(const std::string& channel) const { return !hub_.subscribers(channel).empty(); }

  // Serves until `stop` is set (seen within 50 ms).
  void run(const std::atomic<bool>& stop);

 private:
  struct Listener {
    int fd = -1;
    HostCheck hosts;
    Site site;
    std::size_t connections = 0;  // open, of this site
    std::size_t streams = 0;      // of those, streaming
  };
  struct Timer {
    std::chrono::milliseconds period;
    Clock::time_point next;
    std::function<void()> fn;
  };
  struct Done {
    std::uint64_t id;
    std::uint64_t request_seq;
    Response response;
  };

  void accept_all(std::size_t site);
  bool evict_one(std::size_t site);
  void readable(Connection& c);
  void writable(Connection& c);
  void process(Connection& c);  // parses what arrived and acts on it
  void head_done(Connection& c);
  void dispatch(Connection& c);
  void respond(Connection& c, Response r);
  void finish_write(Connection& c);
  void set_mask(Connection& c, std::uint32_t mask);
  // `reset`: abortive (RST), dropping what the kernel still holds for it.
  void close(Connection& c, bool reset = false);
  void check_deadlines(Clock::time_point now);
  void take_done();
  void serve_ready();                            // the pipelined requests held back last round
  void answer_late_waits(Clock::time_point now);  // routes past their answer_within
  Connection* find(std::uint64_t id);
  const Route* match(const Site& site, const Request& r, bool& path_known) const;

  const ServerConfig config_;
  std::vector<std::pair<std::string, std::string>> headers_;
  int epoll_fd_ = -1;
  int wake_fd_ = -1;      // eventfd: a worker finished
  int spare_fd_ = -1;     // given up to accept (and close) a connection when out of descriptors
  std::vector<std::unique_ptr<Listener>> listeners_;
  std::unordered_map<int, std::unique_ptr<Connection>> connections_;  // by fd
  std::unordered_map<std::uint64_t, int> fd_of_;                     // by id
  std::uint64_t next_id_ = 1;
  StreamHub hub_;
  std::vector<Timer> timers_;
  std::mutex done_mutex_;
  std::vector<Done> done_;
  std::vector<std::uint64_t> ready_;           // connections with a pipelined request to serve
  std::vector<std::uint64_t> bounded_waits_;   // connections waiting on a route with answer_within
  // Destroyed first (declared last): their threads finish before what they post to goes.
  std::unique_ptr<WorkQueue> control_, reader_, urgent_;
};

}  // namespace hapticlab::console::http
