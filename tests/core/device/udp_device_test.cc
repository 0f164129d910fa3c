// UdpDevice against a fake driver on loopback (a real socket in a thread):
// the handshake, what a read ignores and counts (forgeries among it), the
// timeout, and what a handshake that fails says.
#include "core/device/udp_device.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <sys/stat.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <set>
#include <chrono>
#include <fstream>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/common/secret_file.h"
#include "core/device/udp_protocol.h"
#include "core/common/clock.h"
#include "testing/scratch_dir.h"

namespace hapticlab {
namespace {

using ::testing::HasSubstr;

udp::Key key_from_hex(const std::string& hex) {
  const std::string raw = hex_bytes(hex);
  return udp::Key(std::as_bytes(std::span(raw.data(), raw.size())));
}
const std::string kKeyHex = "00112233445566778899aabbccddeeff0f1e2d3c4b5a69788796a5b4c3d2e1f0";
const std::string kOtherKeyHex = "ffeeddccbbaa99887766554433221100f0e1d2c3b4a5968778695a4b3c2d1e0f";

// A UDP socket bound to a free loopback port, which goes to `port`.
int bind_loopback_udp(int& port) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("bind");
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  port = ntohs(a.sin_port);
  return fd;
}

// A driver that answers HELLO and the control requests itself (with `key`,
// in the host's session) and hands each POLL to `on_poll`, which sends
// what the test wants.
class FakeDriver {
 public:
  using OnPoll = std::function<void(FakeDriver&, const udp::Header& poll)>;
  explicit FakeDriver(OnPoll on_poll, udp::Key key = {}) : key_(std::move(key)), on_poll_(std::move(on_poll)) {
    fd_ = bind_loopback_udp(port_);
    thread_ = std::thread([this] { serve(); });
  }
  ~FakeDriver() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
  }
  int port() const { return port_; }

  // The header of a datagram of the driver's in the session (its own
  // sequence `seq`).
  udp::Header header(udp::Type type, std::uint32_t seq) const {
    return udp::Header{type, seq, 0.0, host_nonce_, device_nonce_};
  }
  // Sends a STATE of the driver's, made with `key` (default: the driver's).
  void send_state(std::uint32_t seq, std::uint32_t echo, double insertion_m, const udp::Key* key = nullptr) {
    send_state(header(udp::Type::kState, seq), echo, insertion_m, key);
  }
  void send_state(const udp::Header& h, std::uint32_t echo, double insertion_m, const udp::Key* key = nullptr) {
    udp::State s;
    s.echo_sequence = echo;
    s.position[0][kJointInsertion] = insertion_m;
    std::array<std::byte, udp::kMaxDatagramBytes> b;
    send_raw(b.data(), udp::encode(h, s, key != nullptr ? *key : key_, b.data()));
  }
  void send_raw(const std::byte* data, std::size_t n) {
    ::sendto(fd_, data, n, 0, reinterpret_cast<sockaddr*>(&peer_), peer_len_);
  }
  // The host's address, once it has sent something.
  const sockaddr_in& peer() const { return peer_; }
  std::uint32_t next_seq() { return ++seq_; }
  std::uint32_t seq_ = 0;
  const udp::Key key_;
  std::uint64_t host_nonce_ = 0;
  const std::uint64_t device_nonce_ = 0x0123456789abcdefull;

 private:
  void serve() {
    std::array<std::byte, 2048> buf;
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      peer_len_ = sizeof peer_;
      const ssize_t n = ::recvfrom(fd_, buf.data(), buf.size(), 0, reinterpret_cast<sockaddr*>(&peer_), &peer_len_);
      udp::Header h;
      if (n <= 0 || udp::decode_header(buf.data(), static_cast<std::size_t>(n), key_, h) != udp::Verdict::kOk)
        continue;
      std::array<std::byte, udp::kMaxDatagramBytes> out;
      if (h.type == udp::Type::kHello) {
        host_nonce_ = h.host_nonce;
        udp::HelloReply r;
        r.echo_sequence = h.sequence;
        r.flags = udp::kFlagCalibrated;
        std::memcpy(r.name.data(), "fake", 5);
        r.ratings = workstation_ratings();
        send_raw(out.data(), udp::encode(header(udp::Type::kHelloReply, next_seq()), r, key_, out.data()));
      } else if (h.type == udp::Type::kConfigure || h.type == udp::Type::kActivate ||
                 h.type == udp::Type::kDeactivate) {
        send_raw(out.data(), udp::encode(header(udp::Type::kAck, next_seq()),
                                         udp::Ack{h.sequence, DeviceStatus::kOk}, key_, out.data()));
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
    std::size_t n = udp::encode(d.header(udp::Type::kState, d.next_seq()), bad, d.key_, b.data());
    b[n - 1] ^= std::byte{1};                                     // rejected: MAC (corrupted)
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
  EXPECT_EQ(c.malformed, 3u);
  EXPECT_EQ(c.rejected_mac, 3u);  // without a key the MAC is a checksum: a flipped bit fails it
  EXPECT_EQ(c.stale, 3u);
  EXPECT_EQ(c.out_of_order, 3u);
  EXPECT_EQ(c.timeouts, 0u);
  EXPECT_EQ(c.received, 3u + 3u * 5u);  // HELLO_REPLY, 2 ACKs, 5 per poll
  const auto counters = device.counters();
  ASSERT_GE(counters.size(), 11u);
  EXPECT_EQ(counters[4], (std::pair<std::string, std::uint64_t>{"malformed", 3}));
  EXPECT_EQ(counters[6], (std::pair<std::string, std::uint64_t>{"rejected_mac", 3}));
  EXPECT_EQ(counters[9], (std::pair<std::string, std::uint64_t>{"send_failed", 0}));
  EXPECT_EQ(counters[10], (std::pair<std::string, std::uint64_t>{"authenticated", 0}));
}

TEST(UdpDeviceTest, ForgedStatesAreIgnoredAndCountedByWhatGaveThemAway) {
  // A keyed bridge. Before each good STATE come five that a forger could
  // send, each carrying -1 m so a read that took one shows: from another
  // port, made with another key, made without a key, and two with a
  // correct MAC but another session's nonce (a replay of an earlier
  // session, which the key alone does not catch).
  testing::ScratchDir dir;
  const std::string key_file = (dir.path() / "bridge.key").string();
  create_secret_file(key_file, kKeyHex);
  const udp::Key other_key = key_from_hex(kOtherKeyHex), no_key;
  const int stranger = ::socket(AF_INET, SOCK_DGRAM, 0);
  int polls = 0;
  FakeDriver driver(
      [&](FakeDriver& d, const udp::Header& poll) {
        ++polls;
        std::array<std::byte, udp::kMaxDatagramBytes> b;
        udp::State s;
        s.echo_sequence = poll.sequence;
        s.position[0][kJointInsertion] = -1.0;
        const std::size_t n = udp::encode(d.header(udp::Type::kState, d.next_seq()), s, d.key_, b.data());
        ::sendto(stranger, b.data(), n, 0, reinterpret_cast<const sockaddr*>(&d.peer()), sizeof d.peer());
        d.send_state(d.next_seq(), poll.sequence, -1.0, &other_key);
        d.send_state(d.next_seq(), poll.sequence, -1.0, &no_key);
        udp::Header replayed = d.header(udp::Type::kState, d.next_seq());
        replayed.host_nonce ^= 1;
        d.send_state(replayed, poll.sequence, -1.0);
        replayed = d.header(udp::Type::kState, d.next_seq());
        replayed.device_nonce ^= 1;
        d.send_state(replayed, poll.sequence, -1.0);
        d.send_state(d.next_seq(), poll.sequence, 0.010 + 0.001 * polls);
      },
      key_from_hex(kKeyHex));
  UdpDeviceOptions options = options_for(driver.port());
  options.key_file = key_file;
  UdpDevice device(options);
  EXPECT_TRUE(device.authenticated());
  VirtualClock clock;
  ASSERT_EQ(device.configure(DeviceConfig{}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  for (int k = 1; k <= 3; ++k) {
    DeviceReading r;
    ASSERT_EQ(device.read(r), DeviceStatus::kOk) << "poll " << k;
    EXPECT_DOUBLE_EQ(r.position[0][kJointInsertion], 0.010 + 0.001 * k);
  }
  ::close(stranger);
  const UdpDevice::Counts c = device.counts();
  EXPECT_EQ(c.wrong_source, 3u);
  EXPECT_EQ(c.rejected_mac, 6u);
  EXPECT_EQ(c.wrong_nonce, 6u);
  EXPECT_EQ(c.malformed + c.stale + c.out_of_order + c.timeouts, 0u);
  EXPECT_EQ(c.received, 3u + 3u * 5u);  // from the driver's port: HELLO_REPLY, 2 ACKs, 5 per poll
  std::map<std::string, std::uint64_t> stored;
  for (const auto& [name, value] : device.counters()) stored[name] = value;
  EXPECT_EQ(stored["rejected_mac"], 6u);
  EXPECT_EQ(stored["wrong_nonce"], 6u);
  EXPECT_EQ(stored["wrong_source"], 3u);
  EXPECT_EQ(stored["authenticated"], 1u);
}

// A driver that answers every datagram with what `reply` makes of it.
class Responder {
 public:
  using Reply = std::function<std::vector<std::byte>(const udp::Header& request)>;
  explicit Responder(Reply reply) : reply_(std::move(reply)) {
    fd_ = bind_loopback_udp(port_);
    thread_ = std::thread([this] {
      std::array<std::byte, 2048> buf;
      while (!stop_) {
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, 20) <= 0) continue;
        sockaddr_in from{};
        socklen_t from_len = sizeof from;
        const ssize_t n = ::recvfrom(fd_, buf.data(), buf.size(), 0, reinterpret_cast<sockaddr*>(&from), &from_len);
        if (n < static_cast<ssize_t>(udp::kHeaderBytes)) continue;
        // Read without checking the MAC: this driver answers whatever comes.
        udp::Header h;
        std::memcpy(&h.sequence, buf.data() + 8, 4);
        std::memcpy(&h.host_nonce, buf.data() + 16, 8);
        const std::vector<std::byte> r = reply_(h);
        ::sendto(fd_, r.data(), r.size(), 0, reinterpret_cast<sockaddr*>(&from), from_len);
      }
    });
  }
  ~Responder() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
  }
  int port() const { return port_; }

 private:
  Reply reply_;
  int fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

std::vector<std::byte> hello_reply(const udp::Header& hello, const udp::Key& key) {
  udp::HelloReply r;
  r.echo_sequence = hello.sequence;
  std::vector<std::byte> out(udp::kMaxDatagramBytes);
  out.resize(udp::encode(udp::Header{udp::Type::kHelloReply, 1, 0.0, hello.host_nonce, 99}, r, key, out.data()));
  return out;
}

std::string handshake_refusal(int port, const std::string& key_file) {
  UdpDeviceOptions o = options_for(port);
  o.handshake_timeout_ms = 150;  // every driver here answers at once, or never
  o.key_file = key_file;
  try {
    UdpDevice device(o);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(opened)";
}

TEST(UdpDeviceTest, AHandshakeThatFailsSaysWhatCameBackInstead) {
  testing::ScratchDir dir;
  const std::string key_file = (dir.path() / "bridge.key").string();
  create_secret_file(key_file, kKeyHex);
  {  // A driver with another key.
    Responder r([](const udp::Header& h) { return hello_reply(h, key_from_hex(kOtherKeyHex)); });
    const std::string why = handshake_refusal(r.port(), key_file);
    EXPECT_THAT(why, HasSubstr("authentication failed"));
    EXPECT_THAT(why, HasSubstr("the key in device-option key_file " + key_file));
  }
  {  // A driver without a key, a host with one.
    Responder r([](const udp::Header& h) { return hello_reply(h, udp::Key{}); });
    const std::string why = handshake_refusal(r.port(), key_file);
    EXPECT_THAT(why, HasSubstr("answers without a key, but device-option key_file " + key_file));
    EXPECT_THAT(why, HasSubstr("--key-file"));
  }
  {  // A driver with a key, a host without one.
    Responder r([](const udp::Header& h) { return hello_reply(h, key_from_hex(kKeyHex)); });
    EXPECT_THAT(handshake_refusal(r.port(), ""),
                HasSubstr("authenticates its datagrams with a key; give HapticLab the same key file: "
                          "--device-option key_file=PATH"));
  }
  {  // A driver written for format version 1 (20-byte header, CRC-32C).
    Responder r([](const udp::Header&) {
      std::vector<std::byte> v1(24 + 440);
      const std::uint32_t magic = udp::kMagic;
      const std::uint16_t version = 1, type = 2;
      std::memcpy(v1.data(), &magic, 4);
      std::memcpy(v1.data() + 4, &version, 2);
      std::memcpy(v1.data() + 6, &type, 2);
      return v1;
    });
    EXPECT_THAT(handshake_refusal(r.port(), ""),
                HasSubstr("answers in format version 1 of the UDP bridge; this HapticLab speaks version 2"));
  }
  {  // A host with a key and nothing that answers it: the file and the cause are named.
    FakeDriver silent([](FakeDriver&, const udp::Header&) {}, key_from_hex(kOtherKeyHex));
    const std::string why = handshake_refusal(silent.port(), key_file);
    EXPECT_THAT(why, HasSubstr("no authenticated answer from udp:127.0.0.1:" + std::to_string(silent.port())));
    EXPECT_THAT(why, HasSubstr("device-option key_file " + key_file));
    EXPECT_THAT(why, HasSubstr("authentication"));
  }
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

// This process's open sockets (file descriptors). Only sockets: the
// listing's own directory descriptor is there while it is read.
std::set<int> open_sockets() {
  std::set<int> out;
  for (const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) {
    std::error_code ec;
    const std::string target = std::filesystem::read_symlink(e.path(), ec).string();
    if (!ec && target.rfind("socket:", 0) == 0) out.insert(std::stoi(e.path().filename()));
  }
  return out;
}

TEST(UdpDeviceTest, ADatagramTheSocketRefusesIsAFaultByNameNotATimeout) {
  FakeDriver driver([](FakeDriver& d, const udp::Header& poll) { d.send_state(d.next_seq(), poll.sequence, 0.1); });
  const std::set<int> before = open_sockets();
  UdpDevice device(options_for(driver.port(), 20));
  std::vector<int> opened;
  for (int fd : open_sockets())
    if (!before.count(fd)) opened.push_back(fd);
  ASSERT_EQ(opened.size(), 1u);  // the device's socket
  VirtualClock clock;
  ASSERT_EQ(device.configure(DeviceConfig{}), DeviceStatus::kOk);
  ASSERT_EQ(device.activate(clock), DeviceStatus::kOk);
  DeviceReading r;
  ASSERT_EQ(device.read(r), DeviceStatus::kOk);
  // The socket swapped for /dev/null: every sendto fails (ENOTSOCK), as a
  // socket whose interface went down or whose buffer is gone would.
  const int null_fd = ::open("/dev/null", O_RDWR | O_CLOEXEC);
  ASSERT_GE(::dup2(null_fd, opened.front()), 0);
  ::close(null_fd);
  // A POLL that never left is a failed read at once, not a wait for an
  // answer that cannot come; a COMMAND that never left is a failed write.
  EXPECT_EQ(device.read(r), DeviceStatus::kReadFailed);
  EXPECT_EQ(device.write(DeviceCommand{}), DeviceStatus::kWriteFailed);
  EXPECT_EQ(device.counts().timeouts, 0u);
  EXPECT_EQ(device.counts().send_failed, 2u);
  EXPECT_EQ(device.fault_detail(), "sending to udp:127.0.0.1:" + std::to_string(driver.port()) +
                                       " failed 2 times (last: " + std::strerror(ENOTSOCK) + ")");
  // The shutdown's zero COMMAND cannot leave either: a fault of the shutdown.
  EXPECT_EQ(device.deactivate(), DeviceStatus::kWriteFailed);
}

TEST(UdpProtocolTest, DecodeRejectsEveryTruncationAndBitFlip) {
  udp::State s;
  s.position[1][kJointGrip] = 0.5;
  std::array<std::byte, udp::kMaxDatagramBytes> b;
  // With and without a key: the MAC catches every change either way.
  for (const udp::Key& key : {udp::Key{}, key_from_hex(kKeyHex)}) {
    const std::size_t n = udp::encode(udp::Header{udp::Type::kState, 7, 1.5, 11, 13}, s, key, b.data());
    ASSERT_EQ(n, udp::kHeaderBytes + udp::kStatePayload + udp::kMacBytes);
    udp::Header h;
    ASSERT_EQ(udp::decode_header(b.data(), n, key, h), udp::Verdict::kOk);
    EXPECT_EQ(h.sequence, 7u);
    EXPECT_EQ(h.time_s, 1.5);
    EXPECT_EQ(h.host_nonce, 11u);
    EXPECT_EQ(h.device_nonce, 13u);
    for (std::size_t len = 0; len < n; ++len)
      EXPECT_NE(udp::decode_header(b.data(), len, key, h), udp::Verdict::kOk) << len;
    for (std::size_t i = 0; i < n; ++i)
      for (int bit = 0; bit < 8; ++bit) {
        auto copy = b;
        copy[i] ^= std::byte(1u << bit);
        EXPECT_NE(udp::decode_header(copy.data(), n, key, h), udp::Verdict::kOk) << "byte " << i << " bit " << bit;
      }
  }
  // Neither side takes the other's choice: a keyed datagram at a keyless
  // receiver and the reverse are refused by their flag, before the MAC.
  const std::size_t n = udp::encode(udp::Header{udp::Type::kState, 7, 1.5, 11, 13}, s, udp::Key{}, b.data());
  udp::Header h;
  EXPECT_EQ(udp::decode_header(b.data(), n, key_from_hex(kKeyHex), h), udp::Verdict::kUnkeyed);
  const std::size_t m = udp::encode(udp::Header{udp::Type::kState, 7, 1.5, 11, 13}, s, key_from_hex(kKeyHex), b.data());
  EXPECT_EQ(udp::decode_header(b.data(), m, udp::Key{}, h), udp::Verdict::kKeyed);
  EXPECT_EQ(udp::decode_header(b.data(), m, key_from_hex(kOtherKeyHex), h), udp::Verdict::kBadMac);
}

}  // namespace
}  // namespace hapticlab
