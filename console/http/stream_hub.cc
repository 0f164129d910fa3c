#include "console/http/stream_hub.h"

#include <stdexcept>

namespace hapticlab::console::http {

void StreamHub::add_channel(const std::string& name, std::function<std::string()> on_join) {
  channels_[name].on_join = std::move(on_join);
}

void StreamHub::subscribe(const std::string& channel, std::uint64_t connection) {
  const auto it = channels_.find(channel);
  if (it == channels_.end()) throw std::logic_error("stream channel '" + channel + "' was never added");
  if (it->second.subscribers.insert(connection).second) channel_of_[connection] = channel;
}

void StreamHub::unsubscribe(std::uint64_t connection) {
  const auto it = channel_of_.find(connection);
  if (it == channel_of_.end()) return;
  channels_[it->second].subscribers.erase(connection);
  channel_of_.erase(it);
}

std::string StreamHub::join_event(const std::string& channel) const {
  const auto it = channels_.find(channel);
  return it != channels_.end() && it->second.on_join ? it->second.on_join() : std::string();
}

const std::set<std::uint64_t>& StreamHub::subscribers(const std::string& channel) const {
  static const std::set<std::uint64_t> none;
  const auto it = channels_.find(channel);
  return it == channels_.end() ? none : it->second.subscribers;
}

}  // namespace hapticlab::console::http
