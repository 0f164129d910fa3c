#pragma once
// DNS rebinding: a page of evil.example whose name the attacker points at
// 127.0.0.1 is, for the browser, of evil.example's origin, so the browser
// lets it read the console's answers; only the Host header it sends tells.
// The console answers only a Host that names the address it is bound to
// (or, bound to loopback, one of the loopback names) with its port.

#include <string>
#include <string_view>
#include <vector>

namespace hapticlab::console::http {

class HostCheck {
 public:
  // `bind_address` as given to --bind ("127.0.0.1", "::1", "localhost",
  // "192.168.1.5", "0.0.0.0"); `port` the port listened on. Loopback
  // binds accept 127.0.0.1, localhost and [::1]; a wildcard bind (0.0.0.0,
  // ::) accepts any IP address literal, never a name (a rebinding needs one).
  HostCheck(const std::string& bind_address, int port);

  // Whether a request with this Host header value may be answered.
  bool allowed(std::string_view host) const;
  // The accepted Host values, for the refusal's message.
  std::string describe() const;

 private:
  std::vector<std::string> names_;  // lower case, IPv6 in brackets, without the port
  bool any_ip_literal_ = false;
  int port_ = 0;
};

}  // namespace hapticlab::console::http
