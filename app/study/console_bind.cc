#include "app/study/console_bind.h"

#include <arpa/inet.h>

#include <CLI/CLI.hpp>

#include "core/device/udp_device.h"

namespace hapticlab::app {

bool console_bind_is_loopback(const std::string& bind) {
  if (bind == "localhost") return true;
  in_addr v4{};
  if (inet_pton(AF_INET, bind.c_str(), &v4) == 1) return is_loopback_ipv4(bind);
  in6_addr v6{};
  if (inet_pton(AF_INET6, bind.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6);
  throw CLI::ValidationError("--bind '" + bind + "'",
                             "is not an IP address; give a numeric IPv4 or IPv6 address of this machine (127.0.0.1, "
                             "0.0.0.0 for every interface, ::1) or localhost");
}

}  // namespace hapticlab::app
