#pragma once
// UdpDevice, the "udp" backend: a device driver in another process or on
// another PC, reached through the UDP bridge (docs/udp_bridge.md,
// udp_protocol.h). Each read() sends a POLL carrying the loop clock's time
// and waits for the STATE that echoes it; each write() sends a COMMAND.
// Request/response keeps a virtual-clock session deterministic: a simulated
// device behind the bridge advances its physics to the time in the POLL.
//
// Trust: with a key (key_file), every datagram carries an HMAC-SHA-256 made
// with it, and the host's random session nonce and the device's; a
// datagram that fails either is ignored and counted (rejected_mac,
// wrong_nonce), so a process that forges the driver's address can neither
// feed readings in nor, at a driver that checks, move a motor. Without a
// key, the host is refused unless it is a loopback address or `insecure`
// is set (docs/udp_bridge.md, "Trust").
//
// Time: the POLL carries the loop's time, the t_s the samples are stored
// with (set_loop_origin()); before a loop runs, the time since activate().
//
// Faults: no valid STATE within timeout_ms -> read() returns kTimeout (the
// loop then ends the trial and commands zero force). A datagram that comes
// from another address or port than the driver's (wrong_source), is
// malformed (magic, version, type, length), fails its MAC (rejected_mac),
// carries another session's nonce (wrong_nonce), is out of order (an older
// device sequence than one already seen) or stale (it answers an earlier
// request) is ignored and counted; counters() reports the counts.
//
// When the far side says it is simulated, the device is also a
// HandAttachment: SET_START_POSE and HAND datagrams carry the simulated
// participant's hand, and STATE carries the hand and motor forces back.
//
// Threads as for Device. read/write/set_hand/halt neither allocate nor
// lock; they block only in the socket calls. Not copyable: the loop and the
// participant hold pointers to it.

#include <netinet/in.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <string>

#include "core/device/device.h"
#include "core/device/hand_attachment.h"
#include "core/device/udp_protocol.h"

namespace hapticlab {

struct UdpDeviceOptions {
  std::string host = "127.0.0.1";  // IPv4 address
  int port = 0;                    // 1..65535
  int timeout_ms = 10;             // 1..1000: longest wait for a STATE
  int handshake_timeout_ms = 1000; // longest wait for HELLO_REPLY and for each ACK
  std::string key_file;            // the shared HMAC key (hex, mode 0600); empty: none
  // Without a key, a host outside 127.0.0.0/8 is refused unless this is set.
  bool insecure = false;
};

// Whether `host` (an IPv4 address in dotted form) is in 127.0.0.0/8; false
// for anything that is not an IPv4 address.
bool is_loopback_ipv4(const std::string& host) noexcept;

class UdpDevice final : public Device, public HandAttachment {
 public:
  // Opens the socket and shakes hands. Throws std::invalid_argument for a
  // bad host, option or key file, or an unauthenticated bridge to a host
  // beyond loopback without `insecure` (before any datagram is sent);
  // std::runtime_error when nothing answers in time, saying what came back
  // instead (another format version, a datagram that failed
  // authentication).
  explicit UdpDevice(const UdpDeviceOptions& options);
  ~UdpDevice() override;
  UdpDevice(const UdpDevice&) = delete;
  // The constructor's checks of `options` that need no socket: the port,
  // timeout_ms and host, the key file, and the trust rule (no key beyond
  // loopback needs `insecure`). Returns the key; throws
  // std::invalid_argument as the constructor does.
  static udp::Key checked_key(const UdpDeviceOptions& options);
  UdpDevice& operator=(const UdpDevice&) = delete;

  // --- Device
  DeviceStatus configure(const DeviceConfig& config) override;
  DeviceStatus activate(const Clock& clock) override;
  DeviceStatus read(DeviceReading& reading) noexcept override;
  // A non-finite entry never leaves this process: a zero COMMAND goes out
  // instead and the call returns kWriteFailed. A COMMAND the socket refuses
  // (sendto fails) is kWriteFailed, and a POLL it refuses makes read()
  // kReadFailed at once: neither is left to look like a timeout.
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() noexcept override;
  void halt() noexcept override;
  void set_loop_origin(double t0_s) noexcept override { origin_s_ = t0_s; }
  double read_timeout_s() const noexcept override { return options_.timeout_ms * 1e-3; }
  const char* name() const noexcept override { return name_.data(); }
  DeviceRatings ratings() const noexcept override { return ratings_; }
  HandAttachment* hand_attachment() noexcept override { return simulated_ ? this : nullptr; }
  std::vector<std::pair<std::string, std::uint64_t>> counters() const override;
  std::string fault_detail() const override;

  // --- HandAttachment (only when the far side is simulated)
  bool set_start_pose(int instrument, const DeviceJoints& position) noexcept override;
  void set_hand(int instrument, const HandCouplings& hand) noexcept override;
  DeviceJoints hand_force(int instrument) const noexcept override;
  DeviceJoints motor_force(int instrument) const noexcept override;

  struct Counts {
    std::uint64_t sent = 0, received = 0;
    std::uint64_t stale = 0, out_of_order = 0, malformed = 0, timeouts = 0;
    std::uint64_t rejected_mac = 0, wrong_nonce = 0, wrong_source = 0;
    std::uint64_t send_failed = 0;  // datagrams the socket refused (sendto failed): each is a fault of its call
  };
  Counts counts() const noexcept;
  // Round trip POLL -> STATE [s], from a histogram of 1 µs bins up to 10 ms
  // (longer ones count as 10 ms); NaN before the first.
  double round_trip_quantile_s(double q) const noexcept;
  bool simulated() const noexcept { return simulated_; }
  bool authenticated() const noexcept { return key_.keyed(); }

 private:
  // The sequence a datagram was given, and whether the socket took it.
  struct Sent {
    std::uint32_t sequence = 0;
    bool ok = false;
  };
  Sent send(udp::Type type, double time_s) noexcept;
  template <typename Payload>
  Sent send(udp::Type type, double time_s, const Payload& payload) noexcept;
  // False when sendto failed: counted in send_failed_, its errno kept for
  // fault_detail().
  bool send_datagram(std::size_t n, const std::byte* data) noexcept;
  // Waits until `deadline_ns` (steady clock) for a datagram of `type`
  // echoing `sequence`; on success the datagram is in rx_ and its header
  // in rx_header_. Everything else that arrives is counted and dropped.
  bool await(udp::Type type, std::uint32_t sequence, std::int64_t deadline_ns) noexcept;
  // Why the handshake found nobody, from what came back meanwhile.
  std::string handshake_failure() const;
  DeviceStatus request_ack(udp::Type type, double time_s, const void* payload, int timeout_ms) noexcept;
  double now_s() const noexcept;

  std::string endpoint_;  // "udp:HOST:PORT", for messages
  UdpDeviceOptions options_;
  int fd_ = -1;
  sockaddr_in peer_{};      // the driver's address: replies from anywhere else are wrong_source
  udp::Key key_;
  // The session's nonces: the host's from the constructor, the device's
  // from its HELLO_REPLY (0 until then). Fixed before the loop runs.
  std::uint64_t host_nonce_ = 0;
  std::uint64_t device_nonce_ = 0;
  // What the handshake saw that it could not take (for its message).
  std::uint64_t seen_other_version_ = 0, seen_unkeyed_ = 0, seen_keyed_ = 0, seen_bad_mac_ = 0;
  std::uint16_t other_version_ = 0;
  std::array<char, udp::kNameBytes> name_{};
  DeviceRatings ratings_;
  bool simulated_ = false;
  const Clock* clock_ = nullptr;
  // The clock's time that is the loop's t_s = 0: activate()'s, then the
  // loop's first update (set_loop_origin). Loop thread once it runs.
  double origin_s_ = 0.0;
  bool active_ = false;
  std::atomic<bool> halted_{false};
  std::atomic<double> last_poll_time_s_{0.0};
  std::atomic<std::uint32_t> tx_sequence_{0};
  bool have_rx_sequence_ = false;
  std::uint32_t rx_sequence_ = 0;
  std::array<std::byte, udp::kMaxDatagramBytes + 16> rx_{};
  std::size_t rx_size_ = 0;
  udp::Header rx_header_;
  udp::State state_;
  // Counts are written by the loop thread and read after it: relaxed atomics
  // keep a concurrent read (a progress line) well defined.
  std::atomic<std::uint64_t> sent_{0}, received_{0}, stale_{0}, out_of_order_{0}, malformed_{0}, timeouts_{0};
  std::atomic<std::uint64_t> rejected_mac_{0}, wrong_nonce_{0}, wrong_source_{0}, send_failed_{0};
  std::atomic<int> last_send_errno_{0};
  static constexpr int kRoundTripBins = 10001;  // 1 µs each; the last holds >= 10 ms
  std::array<std::uint32_t, kRoundTripBins> round_trip_us_{};
  std::uint64_t round_trips_ = 0;
};

}  // namespace hapticlab
