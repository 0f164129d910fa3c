#include "app/device/device_serve_sim.h"

#include <arpa/inet.h>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "app/cli/cli_checks.h"
#include "app/cli/interrupt_flag.h"
#include "core/device/udp_device.h"
#include "core/device/udp_protocol.h"
#include "core/device/udp_sim_server.h"

namespace hapticlab::app {

namespace {

struct ServeSimOptions {
  int port = 0;
  std::string host = "127.0.0.1";
  std::string key_file;
  bool key_file_given = false;  // an empty --key-file is not the option left out
  bool insecure = false;
};

// The key to serve with (none: unauthenticated), after refusing what the
// host side refuses (core/device/udp_device.cc) and a host beyond loopback
// without a key.
udp::Key checked_key(const ServeSimOptions& o) {
  // An empty path, a script's unset variable, must not switch the key off.
  if (o.key_file_given && o.key_file.empty())
    throw CLI::ValidationError("--key-file", "names no file (an empty path); give the key file, or leave the "
                                             "option out to serve on loopback without a key");
  // Parsed before loopback is judged: "localhost" is not beyond loopback,
  // it is not an address at all here.
  in_addr parsed{};
  if (inet_pton(AF_INET, o.host.c_str(), &parsed) != 1)
    throw CLI::ValidationError("--host '" + o.host + "'", "not a numeric IPv4 address; give one such as 127.0.0.1 "
                                                          "(names such as localhost are not looked up)");
  if (!o.key_file.empty() && o.insecure)
    throw CLI::ValidationError("--insecure and --key-file " + o.key_file + " together",
                               "the key authenticates the bridge, --insecure allows it without one; give one of them");
  udp::Key key;
  if (!o.key_file.empty()) key = udp::read_key_file(o.key_file, "--key-file");
  // As the host refuses an unauthenticated bridge beyond loopback, so
  // does its far side: there it would take COMMANDs from anyone.
  if (!key.keyed() && !o.insecure && !is_loopback_ipv4(o.host))
    throw std::invalid_argument("--host " + o.host +
                                ": refused: serving beyond loopback without a key lets anyone on the network send "
                                "COMMANDs; give --key-file PATH (`hapticlab device keygen --out PATH`, the same "
                                "file as the host's --device-option key_file), or say --insecure");
  return key;
}

}  // namespace

void add_device_serve_sim_command(CLI::App& device) {
  auto o = std::make_shared<ServeSimOptions>();
  CLI::App* cmd = device.add_subcommand(
      "serve-sim", "Serve the simulated workstation over the UDP bridge (docs/udp_bridge.md), for "
                   "`session run --device udp:HOST:PORT`; runs until Ctrl-C");
  // Checked at the option, as every whole-number option is (a usage error,
  // exit 2, naming the range), not later by the server (exit 1).
  cmd->add_option("--port", o->port, "UDP port to listen on, 0..65535 (0: any free port, printed)")
      ->required()
      ->check(whole_number_in(0, 65535));
  cmd->add_option("--host", o->host, "IPv4 address to listen on")->capture_default_str();
  CLI::Option* key_option = cmd->add_option(
      "--key-file", o->key_file,
      "The bridge's shared key (hex, mode 600; `hapticlab device keygen`): only datagrams made with it "
      "are served; the host gives the same file as --device-option key_file=PATH");
  cmd->add_flag("--insecure", o->insecure,
                "Serve on an address beyond loopback without --key-file: anyone on the network could then "
                "drive it (docs/udp_bridge.md, \"Trust\")");
  cmd->callback([o, key_option] {
    o->key_file_given = key_option->count() > 0;
    const udp::Key key = checked_key(*o);
    UdpSimServer server(o->host, o->port, key);
    InterruptFlag interrupted;
    // Tests and scripts wait for this line (and read the port from it).
    std::printf("serving the simulated workstation on udp:%s:%d (%s)\n", o->host.c_str(), server.port(),
                server.authenticated() ? ("authenticated with the key in " + o->key_file).c_str()
                                       : "not authenticated: no --key-file");
    std::fflush(stdout);
    server.run(interrupted.flag());
    std::printf("stopped: %llu datagrams received, %llu malformed ignored, %llu rejected: bad MAC, %llu rejected: "
                "wrong session nonce, %llu rejected: repeated or old sequence, %llu HELLOs refused while a "
                "session was live\n",
                static_cast<unsigned long long>(server.received()),
                static_cast<unsigned long long>(server.malformed()),
                static_cast<unsigned long long>(server.rejected_mac()),
                static_cast<unsigned long long>(server.wrong_nonce()),
                static_cast<unsigned long long>(server.out_of_order()),
                static_cast<unsigned long long>(server.busy_hello()));
  });
}

}  // namespace hapticlab::app
