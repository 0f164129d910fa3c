#pragma once
// CRC-32C (Castagnoli; reflected polynomial 0x82F63B78, initial value and
// final xor 0xFFFFFFFF; crc32c(0, "123456789") == 0xE3069283). Used by the
// sample chunks of the study database (db/sample_codec.h); the UDP bridge's
// datagrams used it up to format version 1 (version 2 has a MAC instead,
// core/device/udp_protocol.h). Real-time safe.

#include <cstddef>
#include <cstdint>
#include <span>

namespace hapticlab {

// CRC-32C of `data`, continuing from `crc` (0 to start):
// crc32c(crc32c(0, a), b) == crc32c(0, a + b). Uses the CPU's CRC32
// instruction when it has one (x86-64 SSE 4.2), else crc32c_portable
// (tables, slicing by 8); both give the same value.
std::uint32_t crc32c(std::uint32_t crc, std::span<const std::byte> data) noexcept;
std::uint32_t crc32c_portable(std::uint32_t crc, std::span<const std::byte> data) noexcept;

}  // namespace hapticlab
