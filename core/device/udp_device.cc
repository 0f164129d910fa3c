#include "core/device/udp_device.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "core/common/steady_ns.h"
#include "core/common/clock.h"
#include "core/device/plugin_device.h"

namespace hapticlab {
namespace {

}  // namespace

bool is_loopback_ipv4(const std::string& host) noexcept {
  in_addr a{};
  return inet_pton(AF_INET, host.c_str(), &a) == 1 && (ntohl(a.s_addr) >> 24) == 127;
}

udp::Key UdpDevice::checked_key(const UdpDeviceOptions& options) {
  const std::string endpoint = "udp:" + options.host + ":" + std::to_string(options.port);
  if (options.port < 1 || options.port > 65535)
    throw std::invalid_argument("device " + endpoint + ": port " + std::to_string(options.port) +
                                " is outside 1..65535");
  if (options.timeout_ms < 1 || options.timeout_ms > 1000)
    throw std::invalid_argument("device-option timeout_ms: " + std::to_string(options.timeout_ms) +
                                " is outside 1..1000 (milliseconds)");
  in_addr address{};
  if (inet_pton(AF_INET, options.host.c_str(), &address) != 1)
    throw std::invalid_argument("device " + endpoint + ": host '" + options.host +
                                "' is not an IPv4 address such as 127.0.0.1");
  if (!options.key_file.empty()) {
    if (options.insecure)
      throw std::invalid_argument("device " + endpoint + ": --insecure and device-option key_file " +
                                  options.key_file +
                                  " together: the key authenticates the bridge, --insecure allows it without one; "
                                  "give one of them");
    return udp::read_key_file(options.key_file, "device-option key_file");
  }
  if (!is_loopback_ipv4(options.host) && !options.insecure)
    throw std::invalid_argument(
        "device " + endpoint + ": refused: the UDP bridge to " + options.host +
        ", which is not a loopback address, has no key, so anyone who can send datagrams to this machine or to the "
        "driver could forge device readings and force commands. Authenticate it: make a key with `hapticlab device "
        "keygen --out bridge.key` (or `openssl rand -hex 32 > bridge.key && chmod 600 bridge.key`), give the driver "
        "the same file and add --device-option key_file=bridge.key (docs/udp_bridge.md, \"Trust\"). On a network "
        "you trust, --insecure runs it without a key");
  return udp::Key{};
}

UdpDevice::UdpDevice(const UdpDeviceOptions& options)
    : endpoint_("udp:" + options.host + ":" + std::to_string(options.port)),
      options_(options),
      // Trust is decided before a datagram leaves.
      key_(checked_key(options)) {
  peer_.sin_family = AF_INET;
  peer_.sin_port = htons(static_cast<std::uint16_t>(options.port));
  inet_pton(AF_INET, options.host.c_str(), &peer_.sin_addr);
  host_nonce_ = udp::new_nonce();
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error("device " + endpoint_ + ": cannot create a UDP socket: " + std::strerror(errno));
  // Not connected: a connected socket drops datagrams from other addresses
  // in the kernel, uncounted; await() drops and counts them (wrong_source).

  // Handshake. HELLO again every 100 ms: the first may have gone out
  // before the driver's socket existed.
  const std::int64_t end_ns = steady_ns() + std::int64_t{options.handshake_timeout_ms} * 1'000'000;
  bool answered = false;
  while (!answered && steady_ns() < end_ns) {
    const std::uint32_t seq = send(udp::Type::kHello, 0.0).sequence;
    answered = await(udp::Type::kHelloReply, seq, std::min(end_ns, steady_ns() + 100'000'000));
  }
  if (!answered) {
    ::close(fd_);
    throw std::runtime_error(handshake_failure());
  }
  // The session is the pair of nonces from here on; the device's
  // sequence counts from its HELLO_REPLY.
  device_nonce_ = rx_header_.device_nonce;
  have_rx_sequence_ = true;
  rx_sequence_ = rx_header_.sequence;
  udp::HelloReply hello;
  udp::decode(rx_.data(), hello);
  name_ = hello.name;
  if (name_[0] == '\0') std::memcpy(name_.data(), "udp", 4);
  ratings_ = hello.ratings;
  // The driver's ratings set the loop's range and speed guard: the same
  // rules as a plugin's, before anything is driven.
  if (const std::string bad = check_ratings("device " + endpoint_, ratings_); !bad.empty()) {
    ::close(fd_);
    fd_ = -1;
    throw std::runtime_error(bad);
  }
  simulated_ = (hello.flags & udp::kFlagSimulated) != 0;
}

std::string UdpDevice::handshake_failure() const {
  const std::string within = std::to_string(options_.handshake_timeout_ms) + " ms";
  if (seen_other_version_ > 0)
    return "device: the driver at " + endpoint_ + " answers in format version " + std::to_string(other_version_) +
           " of the UDP bridge; this HapticLab speaks version " + std::to_string(udp::kVersion) +
           " (authenticated datagrams, docs/udp_bridge.md): update the driver";
  if (seen_bad_mac_ > 0)
    return "device: authentication failed: " + std::to_string(seen_bad_mac_) + " datagrams from " + endpoint_ +
           " carry an HMAC that does not match the key in device-option key_file " + options_.key_file +
           "; the driver must use the same key file";
  if (seen_unkeyed_ > 0)
    return "device: authentication: the driver at " + endpoint_ +
           " answers without a key, but device-option key_file " + options_.key_file +
           " asks for authenticated datagrams; start the driver with the same key file (serve-sim: --key-file " +
           options_.key_file + ")";
  if (seen_keyed_ > 0)
    return "device: authentication: the driver at " + endpoint_ +
           " authenticates its datagrams with a key; give HapticLab the same key file: --device-option "
           "key_file=PATH";
  if (key_.keyed())
    return "device: no authenticated answer from " + endpoint_ + " within " + within +
           ": is `hapticlab device serve-sim --port " + std::to_string(options_.port) + " --key-file " +
           options_.key_file + "` or your driver running, and does it use the key in device-option key_file " +
           options_.key_file + "? (authentication: a driver with another key, or none, ignores every datagram)";
  return "device: no device answers at " + endpoint_ + " within " + within +
         "; is `hapticlab device serve-sim --port " + std::to_string(options_.port) +
         "` or your driver running? (a driver that authenticates ignores a host without its key: give it with "
         "--device-option key_file=PATH)";
}

UdpDevice::~UdpDevice() {
  // The loop's clock may be gone by now (it need only outlive the loop that
  // used it): the last POLL's time stands in for it.
  clock_ = nullptr;
  if (active_) deactivate();
  if (fd_ >= 0) ::close(fd_);
}

double UdpDevice::now_s() const noexcept {
  return clock_ != nullptr ? clock_->now_s() - origin_s_ : last_poll_time_s_.load(std::memory_order_relaxed);
}

// Any thread (halt() sends from the watchdog's): the buffer is the
// caller's stack, the key and nonces are fixed, the sequence is atomic.
// Two threads sending at once may reach the driver out of order, and a
// driver drops the older one; that is only ever the watchdog's zero
// COMMAND racing a loop that is not stuck after all, whose own next write
// is zero (halted_) and whose next check ends the trial.
UdpDevice::Sent UdpDevice::send(udp::Type type, double time_s) noexcept {
  std::array<std::byte, udp::kMaxDatagramBytes> buf;
  const udp::Header h{type, tx_sequence_.fetch_add(1, std::memory_order_relaxed) + 1, time_s, host_nonce_,
                      device_nonce_};
  return {h.sequence, send_datagram(udp::encode(h, key_, buf.data()), buf.data())};
}

template <typename Payload>
UdpDevice::Sent UdpDevice::send(udp::Type type, double time_s, const Payload& payload) noexcept {
  std::array<std::byte, udp::kMaxDatagramBytes> buf;
  const udp::Header h{type, tx_sequence_.fetch_add(1, std::memory_order_relaxed) + 1, time_s, host_nonce_,
                      device_nonce_};
  return {h.sequence, send_datagram(udp::encode(h, payload, key_, buf.data()), buf.data())};
}

bool UdpDevice::send_datagram(std::size_t n, const std::byte* data) noexcept {
  // A datagram lost on the way shows up as a timeout of its request; one
  // the socket refused is known here, and said by name.
  if (::sendto(fd_, data, n, MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&peer_), sizeof peer_) ==
      static_cast<ssize_t>(n)) {
    sent_.fetch_add(1, std::memory_order_relaxed);
    return true;
  }
  last_send_errno_.store(errno, std::memory_order_relaxed);
  send_failed_.fetch_add(1, std::memory_order_relaxed);
  return false;
}

bool UdpDevice::await(udp::Type type, std::uint32_t sequence, std::int64_t deadline_ns) noexcept {
  for (;;) {
    sockaddr_in from{};
    socklen_t from_len = sizeof from;
    const ssize_t n =
        ::recvfrom(fd_, rx_.data(), rx_.size(), MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&from), &from_len);
    if (n < 0) {
      if (errno == EINTR) continue;
      // EAGAIN: nothing yet; keep waiting until the deadline.
      const std::int64_t left_ns = deadline_ns - steady_ns();
      if (left_ns <= 0) return false;
      pollfd p{fd_, POLLIN, 0};
      const timespec ts{static_cast<time_t>(left_ns / 1'000'000'000), static_cast<long>(left_ns % 1'000'000'000)};
      ::ppoll(&p, 1, &ts, nullptr);
      continue;
    }
    // Only the driver's address and port: the check a connected socket did
    // in the kernel, counted. (A forger can put the driver's address on a
    // datagram; the MAC is what it cannot make.)
    if (from_len != sizeof from || from.sin_family != AF_INET || from.sin_addr.s_addr != peer_.sin_addr.s_addr ||
        from.sin_port != peer_.sin_port) {
      wrong_source_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    received_.fetch_add(1, std::memory_order_relaxed);
    udp::Header h;
    const udp::Verdict verdict = udp::decode_header(rx_.data(), static_cast<std::size_t>(n), key_, h);
    if (verdict != udp::Verdict::kOk) {
      switch (verdict) {
        case udp::Verdict::kOtherVersion:
          ++seen_other_version_;
          std::memcpy(&other_version_, rx_.data() + 4, sizeof other_version_);
          break;
        case udp::Verdict::kUnkeyed: ++seen_unkeyed_; break;
        case udp::Verdict::kKeyed: ++seen_keyed_; break;
        case udp::Verdict::kBadMac: ++seen_bad_mac_; break;
        default: break;
      }
      (udp::is_rejected_mac(verdict) ? rejected_mac_ : malformed_).fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    // This session's, not a replay of another's: the host's nonce always;
    // the device's once its HELLO_REPLY named it (before, any but 0).
    const bool handshaken = device_nonce_ != 0;
    if (h.host_nonce != host_nonce_ || (handshaken ? h.device_nonce != device_nonce_ : h.device_nonce == 0)) {
      wrong_nonce_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    if (handshaken) {
      if (have_rx_sequence_ && !udp::newer_sequence(h.sequence, rx_sequence_)) {
        out_of_order_.fetch_add(1, std::memory_order_relaxed);
        continue;
      }
      have_rx_sequence_ = true;
      rx_sequence_ = h.sequence;
    }
    // Every reply starts with the sequence of the request it answers.
    std::uint32_t echo = 0;
    std::memcpy(&echo, rx_.data() + udp::kHeaderBytes, sizeof echo);
    const bool is_reply = h.type == udp::Type::kHelloReply || h.type == udp::Type::kAck || h.type == udp::Type::kState;
    if (!is_reply || udp::newer_sequence(echo, sequence)) {
      // A request type, or an answer to a request not yet sent: not from a
      // driver that follows the format.
      malformed_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    if (echo != sequence || h.type != type) {
      stale_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    rx_size_ = static_cast<std::size_t>(n);
    rx_header_ = h;
    return true;
  }
}

DeviceStatus UdpDevice::request_ack(udp::Type type, double time_s, const void* payload, int timeout_ms) noexcept {
  // The sequence the request went out with: a halt() on another thread may
  // take the next one meanwhile.
  Sent sent;
  switch (type) {
    case udp::Type::kConfigure: sent = send(type, time_s, *static_cast<const udp::Configure*>(payload)); break;
    case udp::Type::kSetStartPose: sent = send(type, time_s, *static_cast<const udp::StartPose*>(payload)); break;
    default: sent = send(type, time_s); break;
  }
  if (!sent.ok) return DeviceStatus::kWriteFailed;
  const std::uint32_t seq = sent.sequence;
  if (!await(udp::Type::kAck, seq, steady_ns() + std::int64_t{timeout_ms} * 1'000'000)) {
    timeouts_.fetch_add(1, std::memory_order_relaxed);
    return DeviceStatus::kTimeout;
  }
  udp::Ack ack;
  udp::decode(rx_.data(), ack);
  return ack.status;
}

DeviceStatus UdpDevice::configure(const DeviceConfig& config) {
  if (active_) return DeviceStatus::kInvalidConfig;
  const udp::Configure c{config.nominal_rate_Hz, config.seed};
  return request_ack(udp::Type::kConfigure, 0.0, &c, options_.handshake_timeout_ms);
}

DeviceStatus UdpDevice::activate(const Clock& clock) {
  clock_ = &clock;
  // Times count from here until the loop names its first update (0 on a
  // fresh virtual clock either way).
  origin_s_ = clock.now_s();
  halted_.store(false, std::memory_order_release);
  const DeviceStatus s = request_ack(udp::Type::kActivate, 0.0, nullptr, options_.handshake_timeout_ms);
  active_ = s == DeviceStatus::kOk;
  return s;
}

DeviceStatus UdpDevice::read(DeviceReading& reading) noexcept {
  if (!active_) return DeviceStatus::kNotActive;
  const std::int64_t sent_ns = steady_ns();
  const double t_s = now_s();
  last_poll_time_s_.store(t_s, std::memory_order_relaxed);
  const Sent poll = send(udp::Type::kPoll, t_s);
  if (!poll.ok) return DeviceStatus::kReadFailed;
  if (!await(udp::Type::kState, poll.sequence, sent_ns + std::int64_t{options_.timeout_ms} * 1'000'000)) {
    timeouts_.fetch_add(1, std::memory_order_relaxed);
    return DeviceStatus::kTimeout;
  }
  const std::int64_t rtt_us = (steady_ns() - sent_ns) / 1000;
  ++round_trip_us_[static_cast<std::size_t>(std::clamp<std::int64_t>(rtt_us, 0, kRoundTripBins - 1))];
  ++round_trips_;
  udp::decode(rx_.data(), state_);
  if (state_.status != DeviceStatus::kOk) return state_.status;
  for (const DeviceJoints& j : state_.position)
    for (double v : j)
      if (!std::isfinite(v)) return DeviceStatus::kNonFiniteReading;
  reading.position = state_.position;
  reading.device_time_s = state_.device_time_s;
  return DeviceStatus::kOk;
}

DeviceStatus UdpDevice::write(const DeviceCommand& command) noexcept {
  if (!active_) return DeviceStatus::kNotActive;
  udp::Command c;
  bool finite = true;
  for (const DeviceJoints& j : command.force)
    for (double v : j) finite = finite && std::isfinite(v);
  if (finite && !halted_.load(std::memory_order_acquire)) c.force = command.force;
  const bool sent = send(udp::Type::kCommand, now_s(), c).ok;
  return finite && sent ? DeviceStatus::kOk : DeviceStatus::kWriteFailed;
}

void UdpDevice::halt() noexcept {
  halted_.store(true, std::memory_order_release);
  // Any thread: the loop clock is the loop thread's, so the time of the
  // last POLL stands in for it.
  send(udp::Type::kCommand, last_poll_time_s_.load(std::memory_order_relaxed), udp::Command{});
}

DeviceStatus UdpDevice::deactivate() noexcept {
  if (!active_) return DeviceStatus::kOk;
  active_ = false;
  // A zero COMMAND the socket refused is a fault of the shutdown (the
  // session names it), whatever the DEACTIVATE's fate.
  const bool zero_sent = send(udp::Type::kCommand, now_s(), udp::Command{}).ok;
  // The driver may be gone (that is often why we stop): wait one read
  // timeout for its ACK, not a handshake's.
  const DeviceStatus s = request_ack(udp::Type::kDeactivate, now_s(), nullptr, options_.timeout_ms);
  if (!zero_sent) return DeviceStatus::kWriteFailed;
  return s == DeviceStatus::kTimeout ? DeviceStatus::kOk : s;
}

bool UdpDevice::set_start_pose(int instrument, const DeviceJoints& position) noexcept {
  if (!simulated_ || active_ || (instrument != 0 && instrument != 1)) return false;
  const udp::StartPose p{static_cast<std::uint32_t>(instrument), position};
  return request_ack(udp::Type::kSetStartPose, 0.0, &p, options_.handshake_timeout_ms) == DeviceStatus::kOk;
}

void UdpDevice::set_hand(int instrument, const HandCouplings& hand) noexcept {
  if (!simulated_ || (instrument != 0 && instrument != 1)) return;
  send(udp::Type::kHand, now_s(), udp::Hand{static_cast<std::uint32_t>(instrument), hand});
}

DeviceJoints UdpDevice::hand_force(int instrument) const noexcept {
  if (instrument != 0 && instrument != 1) return {};
  return state_.hand_force[static_cast<std::size_t>(instrument)];
}

DeviceJoints UdpDevice::motor_force(int instrument) const noexcept {
  if (instrument != 0 && instrument != 1) return {};
  return state_.motor_force[static_cast<std::size_t>(instrument)];
}

UdpDevice::Counts UdpDevice::counts() const noexcept {
  Counts c;
  c.sent = sent_.load(std::memory_order_relaxed);
  c.received = received_.load(std::memory_order_relaxed);
  c.stale = stale_.load(std::memory_order_relaxed);
  c.out_of_order = out_of_order_.load(std::memory_order_relaxed);
  c.malformed = malformed_.load(std::memory_order_relaxed);
  c.timeouts = timeouts_.load(std::memory_order_relaxed);
  c.rejected_mac = rejected_mac_.load(std::memory_order_relaxed);
  c.send_failed = send_failed_.load(std::memory_order_relaxed);
  c.wrong_nonce = wrong_nonce_.load(std::memory_order_relaxed);
  c.wrong_source = wrong_source_.load(std::memory_order_relaxed);
  return c;
}

double UdpDevice::round_trip_quantile_s(double q) const noexcept {
  if (round_trips_ == 0) return std::numeric_limits<double>::quiet_NaN();
  const auto rank = static_cast<std::uint64_t>(std::ceil(std::clamp(q, 0.0, 1.0) * static_cast<double>(round_trips_)));
  std::uint64_t seen = 0;
  for (int us = 0; us < kRoundTripBins; ++us) {
    seen += round_trip_us_[static_cast<std::size_t>(us)];
    if (seen >= std::max<std::uint64_t>(rank, 1)) return us * 1e-6;
  }
  return (kRoundTripBins - 1) * 1e-6;
}

std::vector<std::pair<std::string, std::uint64_t>> UdpDevice::counters() const {
  const Counts c = counts();
  std::vector<std::pair<std::string, std::uint64_t>> out = {
      {"packets_sent", c.sent},         {"packets_received", c.received},
      {"stale", c.stale},               {"out_of_order", c.out_of_order},
      {"malformed", c.malformed},       {"timeouts", c.timeouts},
      {"rejected_mac", c.rejected_mac}, {"wrong_nonce", c.wrong_nonce},
      {"wrong_source", c.wrong_source}, {"send_failed", c.send_failed},
      {"authenticated", key_.keyed() ? 1u : 0u}};
  if (round_trips_ > 0) {
    out.emplace_back("round_trip_p50_us", static_cast<std::uint64_t>(std::lround(round_trip_quantile_s(0.5) * 1e6)));
    out.emplace_back("round_trip_p99_us", static_cast<std::uint64_t>(std::lround(round_trip_quantile_s(0.99) * 1e6)));
  }
  return out;
}

std::string UdpDevice::fault_detail() const {
  std::string out;
  if (const std::uint64_t failed = send_failed_.load(std::memory_order_relaxed); failed > 0)
    out = "sending to " + endpoint_ + " failed " + std::to_string(failed) + (failed == 1 ? " time" : " times") +
          " (last: " + std::strerror(last_send_errno_.load(std::memory_order_relaxed)) + ")";
  if (timeouts_.load(std::memory_order_relaxed) > 0)
    out += (out.empty() ? "" : "; ") + std::string("no answer from ") + endpoint_ + " within " +
           std::to_string(options_.timeout_ms) + " ms";
  return out;
}

}  // namespace hapticlab
