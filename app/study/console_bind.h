#pragma once
// What `console --bind ADDR` may be, judged on the parsed address, never on
// its spelling: 127.0.0.2 is as much this machine as 127.0.0.1, and a name
// that is not "localhost" could resolve anywhere.

#include <string>

namespace hapticlab::app {

// Whether the console bound to `bind` is reachable from this machine only:
// an IPv4 address in 127.0.0.0/8 (as serve-sim judges its --host), ::1, or
// localhost. Throws CLI::ValidationError naming --bind and the value for
// anything that is not a numeric IPv4 or IPv6 address or localhost (the
// empty string included).
bool console_bind_is_loopback(const std::string& bind);

}  // namespace hapticlab::app
