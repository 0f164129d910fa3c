#include "console/access_tickets.h"

#include <algorithm>

#include "core/common/secret_file.h"

namespace hapticlab::console {

AccessTickets::AccessTickets(std::chrono::milliseconds lifetime, std::size_t max_outstanding)
    : lifetime_(lifetime), max_outstanding_(std::max<std::size_t>(1, max_outstanding)) {}

std::string AccessTickets::issue(const std::string& path) {
  std::string ticket = random_hex(16);
  const Clock::time_point now = Clock::now();
  std::lock_guard lock(mutex_);
  std::erase_if(tickets_, [&](const auto& t) { return t.second.expires <= now; });
  while (tickets_.size() >= max_outstanding_) {
    const auto oldest = std::min_element(tickets_.begin(), tickets_.end(),
                                         [](const auto& a, const auto& b) { return a.second.order < b.second.order; });
    tickets_.erase(oldest);
  }
  tickets_[ticket] = Entry{path, now + lifetime_, ++issued_};
  return ticket;
}

bool AccessTickets::redeem(std::string_view ticket, const std::string& path) {
  std::lock_guard lock(mutex_);
  const auto it = tickets_.find(ticket);
  if (it == tickets_.end()) return false;
  const bool good = it->second.path == path && Clock::now() < it->second.expires;
  tickets_.erase(it);
  return good;
}

std::string query_value(std::string_view query, std::string_view key) {
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    const std::size_t eq = pair.find('=');
    if (pair.substr(0, eq) == key) return eq == std::string_view::npos ? std::string() : std::string(pair.substr(eq + 1));
    if (amp == std::string_view::npos) break;
    query.remove_prefix(amp + 1);
  }
  return {};
}

}  // namespace hapticlab::console
