#include "console/http/host_check.h"

#include <arpa/inet.h>

#include <algorithm>
#include <cctype>

namespace hapticlab::console::http {
namespace {

std::string host_lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

bool is_ipv4(const std::string& s) {
  in_addr a{};
  return inet_pton(AF_INET, s.c_str(), &a) == 1;
}

bool is_ipv6(const std::string& s) {
  in6_addr a{};
  return inet_pton(AF_INET6, s.c_str(), &a) == 1;
}

}  // namespace

HostCheck::HostCheck(const std::string& bind_address, int port) : port_(port) {
  const std::string b = host_lower(bind_address);
  if (b == "127.0.0.1" || b == "localhost" || b == "::1") {
    names_ = {"127.0.0.1", "localhost", "[::1]"};
  } else if (b == "0.0.0.0" || b == "::") {
    any_ip_literal_ = true;
  } else {
    names_ = {is_ipv6(b) ? "[" + b + "]" : b};
  }
}

bool HostCheck::allowed(std::string_view host_header) const {
  const std::string host = host_lower(host_header);
  std::string name = host;
  int port = 80;
  // "[v6]:port", "[v6]", "name:port", "name"
  const std::size_t colon = host.rfind(':');
  const std::size_t bracket = host.rfind(']');
  if (colon != std::string::npos && (bracket == std::string::npos || colon > bracket)) {
    const std::string digits = host.substr(colon + 1);
    if (digits.empty() || digits.size() > 5 || !std::all_of(digits.begin(), digits.end(), ::isdigit)) return false;
    port = std::stoi(digits);
    name = host.substr(0, colon);
  }
  if (port != port_ || name.empty()) return false;
  if (std::find(names_.begin(), names_.end(), name) != names_.end()) return true;
  if (any_ip_literal_) {
    if (is_ipv4(name)) return true;
    if (name.size() > 2 && name.front() == '[' && name.back() == ']') return is_ipv6(name.substr(1, name.size() - 2));
  }
  return false;
}

std::string HostCheck::describe() const {
  if (any_ip_literal_) return "an IP address of this machine with port " + std::to_string(port_);
  std::string out;
  for (const std::string& n : names_) out += (out.empty() ? "" : ", ") + n + ":" + std::to_string(port_);
  return out;
}

}  // namespace hapticlab::console::http
