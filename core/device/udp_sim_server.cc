#include "core/device/udp_sim_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "core/common/steady_ns.h"
#include "core/device/udp_protocol.h"

namespace hapticlab {
namespace {

constexpr std::int64_t kBusyWindow_ns = static_cast<std::int64_t>(UdpSimServer::kBusyWindow_s * 1e9);

}  // namespace

UdpSimServer::UdpSimServer(const std::string& host, int port, udp::Key key) : key_(std::move(key)) {
  if (port < 0 || port > 65535)
    throw std::invalid_argument("--port " + std::to_string(port) + " is outside 0..65535 (0: any free port)");
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  if (inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1)
    throw std::invalid_argument("--host '" + host + "' is not an IPv4 address such as 127.0.0.1");
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(std::string("cannot create a UDP socket: ") + std::strerror(errno));
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd_);
    if (err == EADDRINUSE)
      throw std::runtime_error("udp:" + host + ":" + std::to_string(port) + ": port " + std::to_string(port) +
                               " is in use by another program; choose another with --port (0: any free port)");
    throw std::runtime_error("udp:" + host + ":" + std::to_string(port) + ": cannot listen there: " +
                             std::strerror(err));
  }
  socklen_t len = sizeof addr;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.sin_port);
}

UdpSimServer::~UdpSimServer() {
  if (fd_ >= 0) ::close(fd_);
}

void UdpSimServer::run(const std::atomic<bool>& stop) {
  std::array<std::byte, udp::kMaxDatagramBytes + 16> buf;
  while (!stop.load(std::memory_order_relaxed)) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    sockaddr_storage from{};
    socklen_t from_len = sizeof from;
    const ssize_t n = ::recvfrom(fd_, buf.data(), buf.size(), MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&from),
                                 &from_len);
    if (n < 0) continue;
    received_.fetch_add(1, std::memory_order_relaxed);
    handle(buf.data(), static_cast<std::size_t>(n), &from, from_len);
  }
}

bool UdpSimServer::accepted(const udp::Header& h) {
  switch (h.type) {
    case udp::Type::kHelloReply:
    case udp::Type::kAck:
    case udp::Type::kState:
      malformed_.fetch_add(1, std::memory_order_relaxed);  // a device's message sent to the device
      return false;
    default: break;
  }
  // The session's, and newer than anything it has sent: a datagram of an
  // earlier session, or one of this session sent again, is a replay.
  if (h.type == udp::Type::kHello) {
    if (h.host_nonce == 0 || h.device_nonce != 0) {
      wrong_nonce_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    if (sim_ && h.host_nonce == host_nonce_ && !udp::newer_sequence(h.sequence, host_sequence_)) {
      out_of_order_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    if (h.host_nonce != host_nonce_ && active_ && steady_ns() - last_command_ns_ <= kBusyWindow_ns) {
      busy_hello_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    return true;
  }
  if (!sim_ || h.host_nonce != host_nonce_ || h.device_nonce != device_nonce_) {
    wrong_nonce_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  if (!udp::newer_sequence(h.sequence, host_sequence_)) {
    out_of_order_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  return true;
}

udp::Header UdpSimServer::reply_header(udp::Type type) {
  return udp::Header{type, ++tx_sequence_, sim_ ? sim_->time_s() : 0.0, host_nonce_, device_nonce_};
}

std::size_t UdpSimServer::start_session(const udp::Header& h, std::byte* out) {
  active_ = false;
  host_nonce_ = h.host_nonce;
  device_nonce_ = udp::new_nonce();
  // As open_device() builds the built-in sim, so both compute the same.
  SimDeviceParams params;
  params.max_substep_s = 1e-3;
  sim_ = std::make_unique<SimDevice>(params);
  udp::HelloReply r;
  r.echo_sequence = h.sequence;
  r.flags = udp::kFlagSimulated | udp::kFlagCalibrated;
  std::memcpy(r.name.data(), "sim", 4);
  r.ratings = sim_->ratings();
  return udp::encode(reply_header(udp::Type::kHelloReply), r, key_, out);
}

std::size_t UdpSimServer::poll_state(const udp::Header& h, std::byte* out) {
  DeviceReading reading;
  udp::State s;
  s.echo_sequence = h.sequence;
  s.status = sim_->read(reading);
  s.device_time_s = reading.device_time_s;
  s.position = reading.position;
  for (int i = 0; i < 2; ++i) {
    s.hand_force[static_cast<std::size_t>(i)] = sim_->hand_force(i);
    s.motor_force[static_cast<std::size_t>(i)] = sim_->motor_force(i);
  }
  return udp::encode(reply_header(udp::Type::kState), s, key_, out);
}

void UdpSimServer::handle(const std::byte* data, std::size_t size, const void* from, unsigned from_len) {
  udp::Header h;
  if (const udp::Verdict v = udp::decode_header(data, size, key_, h); v != udp::Verdict::kOk) {
    (udp::is_rejected_mac(v) ? rejected_mac_ : malformed_).fetch_add(1, std::memory_order_relaxed);
    return;
  }
  if (!accepted(h)) return;
  host_sequence_ = h.sequence;

  std::array<std::byte, udp::kMaxDatagramBytes> out;
  const auto send = [&](std::size_t n) {
    ::sendto(fd_, out.data(), n, MSG_NOSIGNAL, static_cast<const sockaddr*>(from), from_len);
  };
  const auto ack = [&](DeviceStatus status) {
    send(udp::encode(reply_header(udp::Type::kAck), udp::Ack{h.sequence, status}, key_, out.data()));
  };
  // The packets' time drives the physics; a non-finite one is ignored.
  if (std::isfinite(h.time_s) && h.type != udp::Type::kHello && h.type != udp::Type::kConfigure &&
      h.type != udp::Type::kSetStartPose)
    clock_.set(h.time_s);

  switch (h.type) {
    case udp::Type::kHello:
      send(start_session(h, out.data()));
      return;
    case udp::Type::kConfigure: {
      udp::Configure c;
      udp::decode(data, c);
      ack(sim_->configure(DeviceConfig{c.nominal_rate_Hz, c.seed}));
      return;
    }
    case udp::Type::kSetStartPose: {
      udp::StartPose p;
      udp::decode(data, p);
      ack(p.instrument <= 1 && sim_->set_start_pose(static_cast<int>(p.instrument), p.position)
              ? DeviceStatus::kOk
              : DeviceStatus::kInvalidConfig);
      return;
    }
    case udp::Type::kActivate: {
      const DeviceStatus status = sim_->activate(clock_);
      active_ = status == DeviceStatus::kOk;
      last_command_ns_ = steady_ns();
      ack(status);
      return;
    }
    case udp::Type::kDeactivate:
      active_ = false;
      ack(sim_->deactivate());
      return;
    case udp::Type::kPoll:
      send(poll_state(h, out.data()));
      return;
    case udp::Type::kCommand: {
      last_command_ns_ = steady_ns();
      udp::Command c;
      udp::decode(data, c);
      DeviceCommand command;
      command.force = c.force;
      sim_->write(command);
      return;
    }
    case udp::Type::kHand: {
      udp::Hand hand;
      udp::decode(data, hand);
      if (hand.instrument <= 1) sim_->set_hand(static_cast<int>(hand.instrument), hand.hand);
      return;
    }
    default: return;
  }
}

}  // namespace hapticlab
