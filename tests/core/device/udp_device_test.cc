// UdpDevice against a fake driver on loopback (a real socket in a thread):
// the handshake, what a read ignores and counts, and the timeout.
#include "core/device/udp_device.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <stdexcept>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/device/udp_protocol.h"
#include "core/loop/clock.h"

namespace hapticlab {
namespace {

using ::testing::HasSubstr;

// A driver that answers HELLO and the control requests itself and hands
// each POLL to `on_poll`, which sends what the test wants.
class FakeDriver {
 public:
  using OnPoll = std::function<void(FakeDriver&, const udp::Header& poll)>;
  explicit FakeDriver(OnPoll on_poll) : on_poll_(std::move(on_poll)) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("bind");
    socklen_t len = sizeof a;
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this] { serve(); });
  }
  ~FakeDriver() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
  }
  int port() const { return port_; }

  // Sends a datagram of the driver's (its own sequence `seq`).
  void send_state(std::uint32_t seq, std::uint32_t echo, double insertion_m) {
    udp::State s;
    s.echo_sequence = echo;
    s.position[0][kJointInsertion] = insertion_m;
    std::array<std::byte, udp::kMaxDatagramBytes> b;
    send_raw(b.data(), udp::encode(udp::Header{udp::Type::kState, seq, 0.0}, s, b.data()));
  }
  void send_raw(const std::byte* data, std::size_t n) {
    ::sendto(fd_, data, n, 0, reinterpret_cast<sockaddr*>(&peer_), peer_len_);
  }
  std::uint32_t next_seq() { return ++seq_; }
  std::uint32_t seq_ = 0;

 private:
  void serve() {
    std::array<std::byte, 2048> buf;
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      peer_len_ = sizeof peer_;
      const ssize_t n = ::recvfrom(fd_, buf.data(), buf.size(), 0, reinterpret_cast<sockaddr*>(&peer_), &peer_len_);
      udp::Header h;
      if (n <= 0 || !udp::decode_header(buf.data(), static_cast<std::size_t>(n), h)) continue;
      std::array<std::byte, udp::kMaxDatagramBytes> out;
      if (h.type == udp::Type::kHello) {
        udp::HelloReply r;
        r.echo_sequence = h.sequence;
        r.flags = udp::kFlagCalibrated;
        std::memcpy(r.name.data(), "fake", 5);
        r.ratings = workstation_ratings();
        send_raw(out.data(), udp::encode(udp::Header{udp::Type::kHelloReply, next_seq(), 0.0}, r, out.data()));
      } else if (h.type == udp::Type::kConfigure || h.type == udp::Type::kActivate ||
                 h.type == udp::Type::kDeactivate) {
        send_raw(out.data(), udp::encode(udp::Header{udp::Type::kAck, next_seq(), 0.0},
                                         udp::Ack{h.sequence, DeviceStatus::kOk}, out.data()));
      } else if (h.type == udp::Type::kPoll) {
        on_poll_(*this, h);
      }
    }
  }

  OnPoll on_poll_;
  int fd_ = -1;
  int port_ = 0;
  sockaddr_in peer_{};
  socklen_t peer_len_ = sizeof peer_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

UdpDeviceOptions options_for(int port, int timeout_ms = 200) {
  UdpDeviceOptions o;
  o.port = port;
  o.timeout_ms = timeout_ms;
  o.handshake_timeout_ms = 300;
  return o;
}

TEST(UdpDeviceTest, HandshakeTakesNameAndRatingsAndSaysHardware) {
  FakeDriver driver([](FakeDriver&, const udp::Header&) {});
  UdpDevice device(options_for(driver.port()));
  EXPECT_STREQ(device.name(), "fake");
  EXPECT_EQ(device.ratings().joint[1][kJointGrip].peak_force, workstation_ratings().joint[1][kJointGrip].peak_force);
  EXPECT_EQ(device.hand_attachment(), nullptr);  // not simulated: a person holds it
}

TEST(UdpDeviceTest, NoDriverIsAClearErrorNamingTheEndpoint) {
  // A port nothing listens on: bind one, note it, close it.
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  const int port = ntohs(a.sin_port);
  try {
    UdpDevice device(options_for(port));
    FAIL() << "opened a device nobody serves";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("no device answers at udp:127.0.0.1:" + std::to_string(port) + " within 300 ms"));
    EXPECT_THAT(e.what(), HasSubstr("device serve-sim --port " + std::to_string(port)));
  }
}

TEST(UdpDeviceTest, StaleOutOfOrderAndMalformedStatesAreIgnoredAndCounted) {
  // Before each good STATE the driver sends one of each bad kind. The good
  // one carries 10 mm + 1 mm per poll, so a read that took a bad one shows.
  int polls = 0;
  FakeDriver driver([&](FakeDriver& d, const udp::Header& poll) {
    ++polls;
    const std::byte garbage[30] = {};
    d.send_raw(garbage, sizeof garbage);                          // malformed: no magic
    const std::uint32_t older = d.next_seq();
    const std::uint32_t newer = d.next_seq();
    d.send_state(newer, poll.sequence - 1, -1.0);                 // stale: answers an earlier request
    d.send_state(older, poll.sequence, -2.0);                     // out of order: older than `newer`
    std::array<std::byte, udp::kMaxDatagramBytes> b;
    udp::State bad;
    bad.echo_sequence = poll.sequence;
    std::size_t n = udp::encode(udp::Header{udp::Type::kState, d.next_seq(), 0.0}, bad, b.data());
    b[n - 1] ^= std::byte{1};                                     // malformed: CRC
    d.send_raw(b.data(), n);
    d.send_state(d.next_seq(), poll.sequence, 0.010 + 0.001 * polls);
  });
  UdpDevice device(options_for(driver.port()));
  VirtualClock clock;
  ASSERT_EQ(device.configure(DeviceConfig{}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  for (int k = 1; k <= 3; ++k) {
    DeviceReading r;
    ASSERT_EQ(device.read(r), DeviceStatus::kOk) << "poll " << k;
    EXPECT_DOUBLE_EQ(r.position[0][kJointInsertion], 0.010 + 0.001 * k);
  }
  const UdpDevice::Counts c = device.counts();
  EXPECT_EQ(c.malformed, 6u);  // 2 per poll
  EXPECT_EQ(c.stale, 3u);
  EXPECT_EQ(c.out_of_order, 3u);
  EXPECT_EQ(c.timeouts, 0u);
  EXPECT_EQ(c.received, 3u + 3u * 5u);  // HELLO_REPLY, 2 ACKs, 5 per poll
  const auto counters = device.counters();
  ASSERT_GE(counters.size(), 6u);
  EXPECT_EQ(counters[4], (std::pair<std::string, std::uint64_t>{"malformed", 6}));
}

TEST(UdpDeviceTest, NoStateWithinTheTimeoutIsDeviceTimeout) {
  FakeDriver driver([](FakeDriver&, const udp::Header&) {});  // never answers a POLL
  UdpDevice device(options_for(driver.port(), 20));
  VirtualClock clock;
  ASSERT_EQ(device.configure(DeviceConfig{}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  DeviceReading r;
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(device.read(r), DeviceStatus::kTimeout);
  const double waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // It waits the timeout, not less; the upper bound only catches a wait of
  // a different order (a loaded CI machine can add tens of ms).
  EXPECT_GE(waited_s, 0.020);
  EXPECT_LT(waited_s, 0.5);
  EXPECT_EQ(device.counts().timeouts, 1u);
  EXPECT_EQ(device.fault_detail(), "no answer from udp:127.0.0.1:" + std::to_string(driver.port()) + " within 20 ms");
}

TEST(UdpProtocolTest, DecodeRejectsEveryTruncationAndBitFlip) {
  udp::State s;
  s.position[1][kJointGrip] = 0.5;
  std::array<std::byte, udp::kMaxDatagramBytes> b;
  const std::size_t n = udp::encode(udp::Header{udp::Type::kState, 7, 1.5}, s, b.data());
  ASSERT_EQ(n, udp::kHeaderBytes + udp::kStatePayload + udp::kCrcBytes);
  udp::Header h;
  ASSERT_TRUE(udp::decode_header(b.data(), n, h));
  EXPECT_EQ(h.sequence, 7u);
  EXPECT_EQ(h.time_s, 1.5);
  for (std::size_t len = 0; len < n; ++len) EXPECT_FALSE(udp::decode_header(b.data(), len, h)) << len;
  for (std::size_t i = 0; i < n; ++i)
    for (int bit = 0; bit < 8; ++bit) {
      auto copy = b;
      copy[i] ^= std::byte(1u << bit);
      EXPECT_FALSE(udp::decode_header(copy.data(), n, h)) << "byte " << i << " bit " << bit;
    }
}

}  // namespace
}  // namespace hapticlab
