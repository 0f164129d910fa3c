#include "app/device_serve_sim.h"

#include <cstdio>
#include <memory>
#include <string>

#include "app/interrupt_flag.h"
#include "core/device/udp_sim_server.h"

namespace hapticlab::app {

void add_device_serve_sim_command(CLI::App& device) {
  struct Opts {
    int port = 0;
    std::string host = "127.0.0.1";
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = device.add_subcommand(
      "serve-sim", "Serve the simulated workstation over the UDP bridge (docs/udp_bridge.md), for "
                   "`session run --device udp:HOST:PORT`; runs until Ctrl-C");
  cmd->add_option("--port", o->port, "UDP port to listen on, 0..65535 (0: any free port, printed)")->required();
  cmd->add_option("--host", o->host, "IPv4 address to listen on")->capture_default_str();
  cmd->callback([o] {
    UdpSimServer server(o->host, o->port);
    InterruptFlag interrupted;
    // Tests and scripts wait for this line (and read the port from it).
    std::printf("serving the simulated workstation on udp:%s:%d\n", o->host.c_str(), server.port());
    std::fflush(stdout);
    server.run(interrupted.flag());
    std::printf("stopped: %llu datagrams received, %llu malformed ignored\n",
                static_cast<unsigned long long>(server.received()),
                static_cast<unsigned long long>(server.malformed()));
  });
}

}  // namespace hapticlab::app
