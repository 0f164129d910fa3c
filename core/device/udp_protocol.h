#pragma once
// The UDP bridge's datagrams, format version 2 (docs/udp_bridge.md has the
// byte tables and the trust model; keep the three in step). Little-endian,
// fixed layout per type:
//
//   offset 0   magic         u32  0x42554C48 ("HLUB" in byte order)
//          4   version       u16  kVersion
//          6   type          u16  Type
//          8   sequence      u32  the sender's own counter, +1 per datagram
//         12   flags         u32  bit 0 (kFlagKeyed): the MAC uses the shared key
//         16   host_nonce    u64  chosen by the host for the session (HELLO)
//         24   device_nonce  u64  chosen by the device for it (HELLO_REPLY); 0 in HELLO
//         32   time_s        f64  host->device: the loop's time [s] (t_s of the
//                                 samples); device->host: the device's clock [s]
//         40   payload       (size fixed by the type)
//   40+payload mac           16 bytes: HMAC-SHA-256 of every byte before it,
//                                 truncated to its first 16 bytes; the key is the
//                                 shared one, or the empty key for a bridge
//                                 without one (then a checksum, not a proof)
//
// Encoding and decoding neither allocate nor throw: the real-time path
// uses them on stack buffers. A Key's HMAC states are computed once.

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include <span>
#include <string>

#include "core/common/hmac_sha256.h"
#include "core/device/device.h"
#include "core/device/hand_attachment.h"

namespace hapticlab::udp {

inline constexpr std::uint32_t kMagic = 0x42554C48u;
inline constexpr std::uint16_t kVersion = 2;
inline constexpr std::size_t kHeaderBytes = 40;
inline constexpr std::size_t kMacBytes = 16;
inline constexpr std::size_t kNameBytes = 32;

enum class Type : std::uint16_t {
  kHello = 1,         // host->device, no payload; answered by kHelloReply
  kHelloReply = 2,    // device->host
  kConfigure = 3,     // host->device; answered by kAck
  kActivate = 4,      // host->device; answered by kAck
  kDeactivate = 5,    // host->device; answered by kAck
  kAck = 6,           // device->host
  kPoll = 7,          // host->device, no payload; answered by kState
  kState = 8,         // device->host
  kCommand = 9,       // host->device, not answered
  kSetStartPose = 10, // host->device, simulated devices; answered by kAck
  kHand = 11,         // host->device, simulated devices, not answered
};

// Payload sizes [bytes] per type.
inline constexpr std::size_t kHelloReplyPayload = 4 + 4 + kNameBytes + 2 * kNumDeviceJoints * 5 * 8;  // 440
inline constexpr std::size_t kConfigurePayload = 16;
inline constexpr std::size_t kAckPayload = 8;
inline constexpr std::size_t kStatePayload = 4 + 4 + 8 + 3 * 2 * kNumDeviceJoints * 8;  // 256
inline constexpr std::size_t kCommandPayload = 2 * kNumDeviceJoints * 8;                // 80
inline constexpr std::size_t kSetStartPosePayload = 8 + kNumDeviceJoints * 8;           // 48
inline constexpr std::size_t kHandPayload = 8 + kNumDeviceJoints * 6 * 8;               // 248
// Payload size of a type; SIZE_MAX for an unknown type.
std::size_t payload_bytes(Type type) noexcept;
inline constexpr std::size_t kMaxDatagramBytes = kHeaderBytes + kHelloReplyPayload + kMacBytes;

// HELLO_REPLY flags.
inline constexpr std::uint32_t kFlagSimulated = 1u;   // a simulated participant can hold it (SET_START_POSE, HAND)
inline constexpr std::uint32_t kFlagCalibrated = 2u;  // homed; a device without it refuses ACTIVATE

// Header flags.
inline constexpr std::uint32_t kFlagKeyed = 1u;

struct Header {
  Type type = Type::kHello;
  std::uint32_t sequence = 0;
  double time_s = 0.0;
  std::uint64_t host_nonce = 0;
  std::uint64_t device_nonce = 0;
};

// The key a side authenticates with: the shared secret from a key file, or
// none (the empty HMAC key: datagrams are checked for corruption, and
// anyone can forge them). Immutable once made; read by any thread.
class Key {
 public:
  Key() noexcept = default;
  // secret: at least kMinKeyBytes; throws std::invalid_argument otherwise.
  explicit Key(std::span<const std::byte> secret);
  bool keyed() const noexcept { return keyed_; }
  const HmacSha256& hmac() const noexcept { return hmac_; }

 private:
  HmacSha256 hmac_;
  bool keyed_ = false;
};
inline constexpr std::size_t kMinKeyBytes = 16;  // 32 hex digits, 128 bits

// Reads a key file: the key as hex digits (at least 32) on one line, in a
// file only its owner may read or write (core/common/secret_file.h).
// `what` names the setting in messages ("device-option key_file",
// "--key-file"). Throws std::invalid_argument naming the file and the rule
// broken.
Key read_key_file(const std::string& path, const std::string& what);

// A fresh random session nonce, never 0 (0 means "not yet chosen").
// Control threads only: it asks the kernel (getrandom). Throws
// std::runtime_error if the kernel gives none.
std::uint64_t new_nonce();

struct HelloReply {
  std::uint32_t echo_sequence = 0;
  std::uint32_t flags = 0;
  std::array<char, kNameBytes> name{};  // NUL-padded
  DeviceRatings ratings;                // per instrument, joint: min, max, continuous, peak, max_velocity
};
struct Configure {
  double nominal_rate_Hz = 1000.0;
  std::uint64_t seed = 0;
};
struct Ack {
  std::uint32_t echo_sequence = 0;
  DeviceStatus status = DeviceStatus::kOk;
};
struct State {
  std::uint32_t echo_sequence = 0;  // the POLL this answers
  DeviceStatus status = DeviceStatus::kOk;
  double device_time_s = 0.0;
  std::array<DeviceJoints, 2> position{};
  std::array<DeviceJoints, 2> hand_force{};   // simulated devices; zero otherwise
  std::array<DeviceJoints, 2> motor_force{};  // simulated devices; zero otherwise
};
struct Command {
  std::array<DeviceJoints, 2> force{};
};
struct StartPose {
  std::uint32_t instrument = 0;
  DeviceJoints position{};
};
struct Hand {
  std::uint32_t instrument = 0;
  HandCouplings hand{};  // per joint: reference_position, reference_velocity, stiffness, damping, force, mass
};

// Writes header + payload + MAC (with `key`) into `out` (kMaxDatagramBytes);
// returns the datagram's length.
std::size_t encode(const Header& h, const Key& key, std::byte* out) noexcept;  // types without payload
std::size_t encode(const Header& h, const HelloReply& p, const Key& key, std::byte* out) noexcept;
std::size_t encode(const Header& h, const Configure& p, const Key& key, std::byte* out) noexcept;
std::size_t encode(const Header& h, const Ack& p, const Key& key, std::byte* out) noexcept;
std::size_t encode(const Header& h, const State& p, const Key& key, std::byte* out) noexcept;
std::size_t encode(const Header& h, const Command& p, const Key& key, std::byte* out) noexcept;
std::size_t encode(const Header& h, const StartPose& p, const Key& key, std::byte* out) noexcept;
std::size_t encode(const Header& h, const Hand& p, const Key& key, std::byte* out) noexcept;

// What decode_header found, in the order it checks.
enum class Verdict : std::uint8_t {
  kOk,
  kMalformed,     // not a datagram of the format: magic, a known type, that type's length
  kOtherVersion,  // the magic, but another format version (a driver written for version 1)
  kUnkeyed,       // this side has a key; the datagram says it was sent without one
  kKeyed,         // this side has no key; the datagram says it was sent with one
  kBadMac,        // the MAC does not verify: forged, corrupted, or made with another key
};
// True for the verdicts a receiver counts as rejected_mac.
constexpr bool is_rejected_mac(Verdict v) noexcept {
  return v == Verdict::kUnkeyed || v == Verdict::kKeyed || v == Verdict::kBadMac;
}
// Checks magic, version, a known type, the length that type has, the keyed
// flag against `key` and the MAC; fills `h` when kOk. The nonces and the
// sequence are the caller's to check: only it knows the session.
Verdict decode_header(const std::byte* data, std::size_t size, const Key& key, Header& h) noexcept;
// Whether sequence `a` comes after `b`. Sequences wrap after 2^32
// datagrams (50 days at 1 kHz); compared modulo 2^32 so the wrap is not an
// error.
constexpr bool newer_sequence(std::uint32_t a, std::uint32_t b) noexcept {
  return static_cast<std::int32_t>(a - b) > 0;
}

// Payload decoders, for a datagram decode_header accepted with that type.
void decode(const std::byte* data, HelloReply& p) noexcept;
void decode(const std::byte* data, Configure& p) noexcept;
void decode(const std::byte* data, Ack& p) noexcept;
void decode(const std::byte* data, State& p) noexcept;
void decode(const std::byte* data, Command& p) noexcept;
void decode(const std::byte* data, StartPose& p) noexcept;
void decode(const std::byte* data, Hand& p) noexcept;

}  // namespace hapticlab::udp
