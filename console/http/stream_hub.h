#pragma once
// Server-sent event streams, fanned out: a channel ("operator",
// "participant") has subscribers (connections), and one event built once
// per tick goes to all of them, so a stream costs a buffer, not a thread.
// How many streams a site may hold is the server's to cap (http_server.h).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>

namespace hapticlab::console::http {

class StreamHub {
 public:
  // A channel; `on_join` (may be null) makes the first event a new
  // subscriber gets (the state so far), "" for none.
  void add_channel(const std::string& name, std::function<std::string()> on_join);
  bool has_channel(const std::string& name) const { return channels_.count(name) != 0; }

  // Throws std::logic_error for a channel never added.
  void subscribe(const std::string& channel, std::uint64_t connection);
  void unsubscribe(std::uint64_t connection);
  std::string join_event(const std::string& channel) const;
  const std::set<std::uint64_t>& subscribers(const std::string& channel) const;
  std::size_t streams() const noexcept { return channel_of_.size(); }

 private:
  struct Channel {
    std::function<std::string()> on_join;
    std::set<std::uint64_t> subscribers;
  };
  std::map<std::string, Channel> channels_;
  std::map<std::uint64_t, std::string> channel_of_;
};

}  // namespace hapticlab::console::http
