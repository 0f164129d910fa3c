#pragma once
// Server-sent event streams, fanned out: a channel ("live", "participant")
// has subscribers (connections), and one event built once per tick goes to
// all of them, so a stream costs a buffer, not a thread. The number of
// streams is capped: one past the cap is refused by name.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>

namespace hapticlab::console::http {

class StreamHub {
 public:
  explicit StreamHub(std::size_t max_streams) : max_streams_(max_streams) {}

  // A channel; `on_join` (may be null) makes the first event a new
  // subscriber gets (the state so far), "" for none.
  void add_channel(const std::string& name, std::function<std::string()> on_join);
  bool has_channel(const std::string& name) const { return channels_.count(name) != 0; }

  // False when max_streams streams are open already.
  bool subscribe(const std::string& channel, std::uint64_t connection);
  void unsubscribe(std::uint64_t connection);
  std::string join_event(const std::string& channel) const;
  const std::set<std::uint64_t>& subscribers(const std::string& channel) const;
  std::size_t streams() const noexcept { return stream_count_; }
  std::size_t max_streams() const noexcept { return max_streams_; }

 private:
  struct Channel {
    std::function<std::string()> on_join;
    std::set<std::uint64_t> subscribers;
  };
  const std::size_t max_streams_;
  std::map<std::string, Channel> channels_;
  std::map<std::uint64_t, std::string> channel_of_;
  std::size_t stream_count_ = 0;
};

}  // namespace hapticlab::console::http
