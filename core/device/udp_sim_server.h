#pragma once
// The simulated workstation (SimDevice) behind the UDP bridge: the far side
// of UdpDevice, as `hapticlab device serve-sim` runs it in its own process.
// Its SimDevice's clock is the time the packets carry (the host loop's
// clock), so a virtual-clock session over the bridge computes what the
// built-in sim computes. A HELLO starts a fresh SimDevice (each trial opens
// the device anew). A malformed datagram is counted and ignored; every
// request is answered at the address it came from.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "core/device/sim_device.h"
#include "core/loop/clock.h"

namespace hapticlab {

class UdpSimServer {
 public:
  // Binds host:port (port 0: the system picks one, see port()). Throws
  // std::invalid_argument for a host that is not an IPv4 address,
  // std::runtime_error naming the port when it is in use.
  UdpSimServer(const std::string& host, int port);
  ~UdpSimServer();
  UdpSimServer(const UdpSimServer&) = delete;
  UdpSimServer& operator=(const UdpSimServer&) = delete;

  int port() const noexcept { return port_; }
  // Serves until `stop` becomes true (checked at least every 100 ms).
  void run(const std::atomic<bool>& stop) noexcept;

  std::uint64_t received() const noexcept { return received_.load(std::memory_order_relaxed); }
  std::uint64_t malformed() const noexcept { return malformed_.load(std::memory_order_relaxed); }

 private:
  // A clock that reads the time of the last packet.
  class PacketClock final : public Clock {
   public:
    double now_s() const noexcept override { return now_s_; }
    void sleep_until(double) noexcept override {}
    bool is_virtual() const noexcept override { return true; }
    void set(double t_s) noexcept { now_s_ = t_s; }

   private:
    double now_s_ = 0.0;
  };

  void handle(const std::byte* data, std::size_t size, const void* from, unsigned from_len) noexcept;

  int fd_ = -1;
  int port_ = 0;
  std::unique_ptr<SimDevice> sim_;
  PacketClock clock_;
  std::uint32_t tx_sequence_ = 0;
  std::atomic<std::uint64_t> received_{0}, malformed_{0};
};

}  // namespace hapticlab
