#pragma once
// The UDP bridge's datagrams (docs/udp_bridge.md has the byte tables; keep
// the two in step). Little-endian, fixed layout per type:
//
//   offset 0   magic     u32  0x42554C48 ("HLUB" in byte order)
//          4   version   u16  kUdpVersion
//          6   type      u16  UdpType
//          8   sequence  u32  the sender's own counter, +1 per datagram
//         12   time_s    f64  host->device: the loop clock's time [s];
//                             device->host: the device's clock [s]
//         20   payload   (size fixed by the type)
//   20+payload crc       u32  CRC-32C of every byte before it
//
// Encoding and decoding neither allocate nor throw: the real-time path
// uses them on stack buffers.

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "core/device/device.h"
#include "core/device/hand_attachment.h"

namespace hapticlab::udp {

inline constexpr std::uint32_t kMagic = 0x42554C48u;
inline constexpr std::uint16_t kVersion = 1;
inline constexpr std::size_t kHeaderBytes = 20;
inline constexpr std::size_t kCrcBytes = 4;
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
inline constexpr std::size_t kMaxDatagramBytes = kHeaderBytes + kHelloReplyPayload + kCrcBytes;

// HELLO_REPLY flags.
inline constexpr std::uint32_t kFlagSimulated = 1u;   // a simulated participant can hold it (SET_START_POSE, HAND)
inline constexpr std::uint32_t kFlagCalibrated = 2u;  // homed; a device without it refuses ACTIVATE

struct Header {
  Type type = Type::kHello;
  std::uint32_t sequence = 0;
  double time_s = 0.0;
};

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

// Writes header + payload + CRC into `out` (kMaxDatagramBytes); returns the
// datagram's length.
std::size_t encode(const Header& h, std::byte* out) noexcept;  // types without payload
std::size_t encode(const Header& h, const HelloReply& p, std::byte* out) noexcept;
std::size_t encode(const Header& h, const Configure& p, std::byte* out) noexcept;
std::size_t encode(const Header& h, const Ack& p, std::byte* out) noexcept;
std::size_t encode(const Header& h, const State& p, std::byte* out) noexcept;
std::size_t encode(const Header& h, const Command& p, std::byte* out) noexcept;
std::size_t encode(const Header& h, const StartPose& p, std::byte* out) noexcept;
std::size_t encode(const Header& h, const Hand& p, std::byte* out) noexcept;

// Checks magic, version, a known type, the length that type has and the
// CRC; fills `h`. False for anything malformed.
bool decode_header(const std::byte* data, std::size_t size, Header& h) noexcept;
// Payload decoders, for a datagram decode_header accepted with that type.
void decode(const std::byte* data, HelloReply& p) noexcept;
void decode(const std::byte* data, Configure& p) noexcept;
void decode(const std::byte* data, Ack& p) noexcept;
void decode(const std::byte* data, State& p) noexcept;
void decode(const std::byte* data, Command& p) noexcept;
void decode(const std::byte* data, StartPose& p) noexcept;
void decode(const std::byte* data, Hand& p) noexcept;

}  // namespace hapticlab::udp
