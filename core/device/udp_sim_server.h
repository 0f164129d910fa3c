#pragma once
// The simulated workstation (SimDevice) behind the UDP bridge: the far side
// of UdpDevice, as `hapticlab device serve-sim` runs it in its own process.
// Its SimDevice's clock is the time the packets carry (the host loop's
// clock), so a virtual-clock session over the bridge computes what the
// built-in sim computes. A HELLO starts a fresh SimDevice and a session
// (the host's nonce, a new one of its own; each trial opens the device
// anew). A datagram that is malformed, fails its MAC (with the key, or the
// empty key when there is none), carries another session's nonces or
// repeats an earlier sequence of the session (a replay) is counted and
// ignored: a forged COMMAND moves nothing. A HELLO of another session while
// this one is active and its host sent a COMMAND within kBusyWindow_s is
// refused too (counted as busy_hello): a replayed HELLO, or a second
// program pointed at the same driver, does not take the device from a
// running trial. Every request is answered at the address it came from.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "core/device/sim_device.h"
#include "core/device/udp_protocol.h"
#include "core/common/clock.h"

namespace hapticlab {

class UdpSimServer {
 public:
  // Binds host:port (port 0: the system picks one, see port()). `key`:
  // the shared key the host must use too (default: none). Throws
  // std::invalid_argument for a host that is not an IPv4 address,
  // std::runtime_error naming the port when it is in use.
  UdpSimServer(const std::string& host, int port, udp::Key key = {});
  ~UdpSimServer();
  UdpSimServer(const UdpSimServer&) = delete;
  UdpSimServer& operator=(const UdpSimServer&) = delete;

  int port() const noexcept { return port_; }
  // Serves until `stop` becomes true (checked at least every 100 ms).
  // Throws std::runtime_error only if the kernel has no random numbers for
  // a session nonce.
  void run(const std::atomic<bool>& stop);

  std::uint64_t received() const noexcept { return received_.load(std::memory_order_relaxed); }
  std::uint64_t malformed() const noexcept { return malformed_.load(std::memory_order_relaxed); }
  std::uint64_t rejected_mac() const noexcept { return rejected_mac_.load(std::memory_order_relaxed); }
  std::uint64_t wrong_nonce() const noexcept { return wrong_nonce_.load(std::memory_order_relaxed); }
  std::uint64_t out_of_order() const noexcept { return out_of_order_.load(std::memory_order_relaxed); }
  std::uint64_t busy_hello() const noexcept { return busy_hello_.load(std::memory_order_relaxed); }
  // How recent a COMMAND keeps a session from being taken over by another
  // HELLO [s] (examples/udp_driver/udp_driver.py: COMMAND_TIMEOUT_S).
  static constexpr double kBusyWindow_s = 0.05;
  bool authenticated() const noexcept { return key_.keyed(); }

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

  void handle(const std::byte* data, std::size_t size, const void* from, unsigned from_len);
  // Whether a datagram with a valid header is for this session and new
  // (counting the refusal when not).
  bool accepted(const udp::Header& h);
  // The header of the next reply (its own sequence number).
  udp::Header reply_header(udp::Type type);
  // Starts a new session on HELLO `h`; encodes the reply into `out`,
  // returns its size.
  std::size_t start_session(const udp::Header& h, std::byte* out);
  // Reads the device for POLL `h`; encodes the STATE reply into `out`,
  // returns its size.
  std::size_t poll_state(const udp::Header& h, std::byte* out);

  int fd_ = -1;
  int port_ = 0;
  udp::Key key_;
  std::unique_ptr<SimDevice> sim_;  // null until the first HELLO
  PacketClock clock_;
  std::uint32_t tx_sequence_ = 0;
  // The session: its nonces and the host's newest sequence in it.
  std::uint64_t host_nonce_ = 0, device_nonce_ = 0;
  std::uint32_t host_sequence_ = 0;
  std::atomic<std::uint64_t> received_{0}, malformed_{0}, rejected_mac_{0}, wrong_nonce_{0}, out_of_order_{0},
      busy_hello_{0};
  bool active_ = false;              // ACTIVATE acknowledged, no DEACTIVATE or HELLO since
  std::int64_t last_command_ns_ = 0;  // steady clock, the session's last COMMAND (or ACTIVATE)
};

}  // namespace hapticlab
