#pragma once
// One-time tickets for the operator's routes that a browser must name by
// address: the page's event stream (EventSource sends no header), the
// report in a frame and a download. The page asks for a ticket with the
// token in its header (POST /api/ticket) and puts the ticket, not the
// token, in the address: the address is kept where a participant at the
// same browser can read it (the downloads list, a frame's address), and a
// ticket there is spent (used once, for one path, within 30 s) where the
// token would open every control. Not a cookie: a browser sends cookies by
// host, whatever the port, so the participant screen's window would carry
// it too.

#include <chrono>
#include <cstddef>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

namespace hapticlab::console {

class AccessTickets {
 public:
  using Clock = std::chrono::steady_clock;
  // A ticket is good for `lifetime`; at most `max_outstanding` wait to be
  // used (past it the oldest is dropped, so asking cannot grow memory).
  explicit AccessTickets(std::chrono::milliseconds lifetime = std::chrono::seconds(30),
                         std::size_t max_outstanding = 256);

  // A new ticket (32 hex digits, 128 bits from the kernel) for `path`.
  std::string issue(const std::string& path);
  // True, once, for a ticket issued for exactly `path` that has not
  // expired; the ticket is spent either way.
  bool redeem(std::string_view ticket, const std::string& path);

 private:
  struct Entry {
    std::string path;
    Clock::time_point expires;
    std::uint64_t order;  // issue order, to drop the oldest
  };
  const std::chrono::milliseconds lifetime_;
  const std::size_t max_outstanding_;
  std::mutex mutex_;
  std::map<std::string, Entry, std::less<>> tickets_;
  std::uint64_t issued_ = 0;
};

// The value of `key` in a query string ("a=1&ticket=ab12"), "" when absent.
// Values are taken as sent (tickets are hex digits: nothing to decode).
std::string query_value(std::string_view query, std::string_view key);

}  // namespace hapticlab::console
