#include "core/device/udp_protocol.h"

#include <sys/random.h>

#include <bit>
#include <cerrno>
#include <limits>
#include <stdexcept>

#include "core/common/secret_file.h"

namespace hapticlab::udp {
namespace {

// The wire is little-endian; memcpy of native values is only right on a
// little-endian host, which is every machine this project builds for.
static_assert(std::endian::native == std::endian::little, "the UDP bridge encoder assumes a little-endian host");

class Out {
 public:
  explicit Out(std::byte* p) noexcept : p_(p) {}
  template <typename T>
  void put(T v) noexcept {
    std::memcpy(p_ + n_, &v, sizeof v);
    n_ += sizeof v;
  }
  void joints(const DeviceJoints& j) noexcept {
    for (double v : j) put(v);
  }
  void bytes(const void* src, std::size_t size) noexcept {
    std::memcpy(p_ + n_, src, size);
    n_ += size;
  }
  std::size_t finish(const Key& key) noexcept {
    const Sha256::Digest mac = key.hmac().mac(std::span<const std::byte>(p_, n_));
    bytes(mac.data(), kMacBytes);
    return n_;
  }

 private:
  std::byte* p_;
  std::size_t n_ = 0;
};

class In {
 public:
  explicit In(const std::byte* p) noexcept : p_(p + kHeaderBytes) {}
  template <typename T>
  T get() noexcept {
    T v;
    std::memcpy(&v, p_ + n_, sizeof v);
    n_ += sizeof v;
    return v;
  }
  void joints(DeviceJoints& j) noexcept {
    for (double& v : j) v = get<double>();
  }
  void bytes(void* dst, std::size_t size) noexcept {
    std::memcpy(dst, p_ + n_, size);
    n_ += size;
  }

 private:
  const std::byte* p_;
  std::size_t n_ = 0;
};

Out start(const Header& h, const Key& key, std::byte* out) noexcept {
  Out o(out);
  o.put(kMagic);
  o.put(kVersion);
  o.put(static_cast<std::uint16_t>(h.type));
  o.put(h.sequence);
  o.put(key.keyed() ? kFlagKeyed : std::uint32_t{0});
  o.put(h.host_nonce);
  o.put(h.device_nonce);
  o.put(h.time_s);
  return o;
}

}  // namespace

Key::Key(std::span<const std::byte> secret) : hmac_(secret), keyed_(true) {
  if (secret.size() < kMinKeyBytes)
    throw std::invalid_argument("UDP bridge key: " + std::to_string(secret.size()) + " bytes, must be at least " +
                                std::to_string(kMinKeyBytes));
}

Key read_key_file(const std::string& path, const std::string& what) {
  // 32 hex digits = 16 bytes = 128 bits, HMAC-SHA-256's truncated tag
  // length; `openssl rand -hex 32` and `hapticlab device keygen` give 64.
  const std::string hex = read_secret_file(path, what, SecretRules{.min_chars = 2 * kMinKeyBytes, .min_distinct = 8,
                                                                   .hex_only = true});
  if (hex.size() % 2 != 0)
    throw std::invalid_argument(what + ": " + path + " holds " + std::to_string(hex.size()) +
                                " hex digits, an odd number; a key is whole bytes (e.g. `openssl rand -hex 32`)");
  const std::string raw = hex_bytes(hex);
  return Key(std::as_bytes(std::span(raw.data(), raw.size())));
}

std::uint64_t new_nonce() {
  std::uint64_t nonce = 0;
  while (nonce == 0) {
    const ssize_t n = ::getrandom(&nonce, sizeof nonce, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n != static_cast<ssize_t>(sizeof nonce))
      throw std::runtime_error(std::string("UDP bridge: no random session nonce from the kernel (getrandom: ") +
                               std::strerror(errno) + ")");
  }
  return nonce;
}

std::size_t payload_bytes(Type type) noexcept {
  switch (type) {
    case Type::kHello:
    case Type::kActivate:
    case Type::kDeactivate:
    case Type::kPoll: return 0;
    case Type::kHelloReply: return kHelloReplyPayload;
    case Type::kConfigure: return kConfigurePayload;
    case Type::kAck: return kAckPayload;
    case Type::kState: return kStatePayload;
    case Type::kCommand: return kCommandPayload;
    case Type::kSetStartPose: return kSetStartPosePayload;
    case Type::kHand: return kHandPayload;
  }
  return std::numeric_limits<std::size_t>::max();
}

std::size_t encode(const Header& h, const Key& key, std::byte* out) noexcept { return start(h, key, out).finish(key); }

std::size_t encode(const Header& h, const HelloReply& p, const Key& key, std::byte* out) noexcept {
  Out o = start(h, key, out);
  o.put(p.echo_sequence);
  o.put(p.flags);
  o.bytes(p.name.data(), kNameBytes);
  for (const auto& instrument : p.ratings.joint)
    for (const DeviceJointRating& r : instrument) {
      o.put(r.min_position);
      o.put(r.max_position);
      o.put(r.continuous_force);
      o.put(r.peak_force);
      o.put(r.max_velocity);
    }
  return o.finish(key);
}

std::size_t encode(const Header& h, const Configure& p, const Key& key, std::byte* out) noexcept {
  Out o = start(h, key, out);
  o.put(p.nominal_rate_Hz);
  o.put(p.seed);
  return o.finish(key);
}

std::size_t encode(const Header& h, const Ack& p, const Key& key, std::byte* out) noexcept {
  Out o = start(h, key, out);
  o.put(p.echo_sequence);
  o.put(static_cast<std::int32_t>(p.status));
  return o.finish(key);
}

std::size_t encode(const Header& h, const State& p, const Key& key, std::byte* out) noexcept {
  Out o = start(h, key, out);
  o.put(p.echo_sequence);
  o.put(static_cast<std::int32_t>(p.status));
  o.put(p.device_time_s);
  for (const auto* field : {&p.position, &p.hand_force, &p.motor_force})
    for (const DeviceJoints& j : *field) o.joints(j);
  return o.finish(key);
}

std::size_t encode(const Header& h, const Command& p, const Key& key, std::byte* out) noexcept {
  Out o = start(h, key, out);
  for (const DeviceJoints& j : p.force) o.joints(j);
  return o.finish(key);
}

std::size_t encode(const Header& h, const StartPose& p, const Key& key, std::byte* out) noexcept {
  Out o = start(h, key, out);
  o.put(p.instrument);
  o.put(std::uint32_t{0});
  o.joints(p.position);
  return o.finish(key);
}

std::size_t encode(const Header& h, const Hand& p, const Key& key, std::byte* out) noexcept {
  Out o = start(h, key, out);
  o.put(p.instrument);
  o.put(std::uint32_t{0});
  for (const HandCoupling& c : p.hand) {
    o.put(c.reference_position);
    o.put(c.reference_velocity);
    o.put(c.stiffness);
    o.put(c.damping);
    o.put(c.force);
    o.put(c.mass);
  }
  return o.finish(key);
}

Verdict decode_header(const std::byte* data, std::size_t size, const Key& key, Header& h) noexcept {
  // Version 1 datagrams are 20 header bytes and a CRC: shorter than any
  // of version 2, so the version is looked at before the length.
  if (size < 8) return Verdict::kMalformed;
  std::uint32_t magic;
  std::uint16_t version, type;
  std::memcpy(&magic, data, 4);
  std::memcpy(&version, data + 4, 2);
  std::memcpy(&type, data + 6, 2);
  if (magic != kMagic) return Verdict::kMalformed;
  if (version != kVersion) return Verdict::kOtherVersion;
  const std::size_t payload = payload_bytes(static_cast<Type>(type));
  if (payload == std::numeric_limits<std::size_t>::max() || size != kHeaderBytes + payload + kMacBytes)
    return Verdict::kMalformed;
  std::uint32_t flags;
  std::memcpy(&flags, data + 12, 4);
  // Neither side lets the other choose whether to authenticate: a keyed
  // receiver takes nothing unkeyed (no downgrade by a forger).
  if (key.keyed() && (flags & kFlagKeyed) == 0) return Verdict::kUnkeyed;
  if (!key.keyed() && (flags & kFlagKeyed) != 0) return Verdict::kKeyed;
  if (!key.hmac().verify(std::span<const std::byte>(data, size - kMacBytes),
                         std::span<const std::byte>(data + size - kMacBytes, kMacBytes)))
    return Verdict::kBadMac;
  h.type = static_cast<Type>(type);
  std::memcpy(&h.sequence, data + 8, 4);
  std::memcpy(&h.host_nonce, data + 16, 8);
  std::memcpy(&h.device_nonce, data + 24, 8);
  std::memcpy(&h.time_s, data + 32, 8);
  return Verdict::kOk;
}

void decode(const std::byte* data, HelloReply& p) noexcept {
  In in(data);
  p.echo_sequence = in.get<std::uint32_t>();
  p.flags = in.get<std::uint32_t>();
  in.bytes(p.name.data(), kNameBytes);
  p.name.back() = '\0';
  for (auto& instrument : p.ratings.joint)
    for (DeviceJointRating& r : instrument) {
      r.min_position = in.get<double>();
      r.max_position = in.get<double>();
      r.continuous_force = in.get<double>();
      r.peak_force = in.get<double>();
      r.max_velocity = in.get<double>();
    }
}

void decode(const std::byte* data, Configure& p) noexcept {
  In in(data);
  p.nominal_rate_Hz = in.get<double>();
  p.seed = in.get<std::uint64_t>();
}

namespace {
DeviceStatus to_status(std::int32_t v) noexcept {
  // An unknown code from a newer driver is a failed read, never "ok". The
  // wire carries the statuses up to kTimeout (docs/udp_bridge.md); the later
  // ones (device_crashed, device_hung) are HapticLab's own findings about a
  // plugin's process, which a driver cannot claim.
  return v >= 0 && v <= static_cast<std::int32_t>(DeviceStatus::kTimeout) ? static_cast<DeviceStatus>(v)
                                                                          : DeviceStatus::kReadFailed;
}
}  // namespace

void decode(const std::byte* data, Ack& p) noexcept {
  In in(data);
  p.echo_sequence = in.get<std::uint32_t>();
  p.status = to_status(in.get<std::int32_t>());
}

void decode(const std::byte* data, State& p) noexcept {
  In in(data);
  p.echo_sequence = in.get<std::uint32_t>();
  p.status = to_status(in.get<std::int32_t>());
  p.device_time_s = in.get<double>();
  for (auto* field : {&p.position, &p.hand_force, &p.motor_force})
    for (DeviceJoints& j : *field) in.joints(j);
}

void decode(const std::byte* data, Command& p) noexcept {
  In in(data);
  for (DeviceJoints& j : p.force) in.joints(j);
}

void decode(const std::byte* data, StartPose& p) noexcept {
  In in(data);
  p.instrument = in.get<std::uint32_t>();
  (void)in.get<std::uint32_t>();
  in.joints(p.position);
}

void decode(const std::byte* data, Hand& p) noexcept {
  In in(data);
  p.instrument = in.get<std::uint32_t>();
  (void)in.get<std::uint32_t>();
  for (HandCoupling& c : p.hand) {
    c.reference_position = in.get<double>();
    c.reference_velocity = in.get<double>();
    c.stiffness = in.get<double>();
    c.damping = in.get<double>();
    c.force = in.get<double>();
    c.mass = in.get<double>();
  }
}

}  // namespace hapticlab::udp
