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
// Limits (docs/console.md, "Limits"): a request head of 16 kB and 64
// headers, a body of the route's cap (chunked or not), deadlines for an idle
// connection, a head, a body and a stalled reader, a cap on connections
// (a new one past it drops the oldest idle or slow one) and on streams.

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
};

struct Site {
  std::string name;          // "operator", "participant": for messages
  std::string bind_address;  // as --bind
  int port = 0;              // 0: any free one
  std::vector<Route> routes;
};

struct ServerConfig {
  Limits limits;
  std::size_t max_connections = 512;  // of all sites together
  std::size_t max_streams = 64;       // event streams of all sites together
  std::chrono::milliseconds idle_timeout{15000};   // keep-alive, no request begun
  std::chrono::milliseconds head_timeout{5000};    // from a request's first byte to the end of its head
  std::chrono::milliseconds body_timeout{5000};    // from the end of the head to the end of the body
  std::chrono::milliseconds write_timeout{10000};  // an answer or a stream that the client stops reading
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
  };
  struct Timer {
    std::chrono::milliseconds period;
    Clock::time_point next;
    std::function<void()> fn;
  };
  struct Done {
    std::uint64_t id;
    Response response;
  };

  void accept_all(std::size_t site);
  bool evict_one();
  void readable(Connection& c);
  void writable(Connection& c);
  void process(Connection& c);  // parses what arrived and acts on it
  void head_done(Connection& c);
  void dispatch(Connection& c);
  void respond(Connection& c, Response r);
  void finish_write(Connection& c);
  void set_mask(Connection& c, std::uint32_t mask);
  void close(Connection& c);
  void check_deadlines(Clock::time_point now);
  void take_done();
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
  // Destroyed first (declared last): their threads finish before what they post to goes.
  std::unique_ptr<WorkQueue> control_, reader_;
};

}  // namespace hapticlab::console::http
