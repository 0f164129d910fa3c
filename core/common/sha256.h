#pragma once
// SHA-256 (FIPS 180-4, section 6.2): the hash under the UDP bridge's
// HMAC (hmac_sha256.h), and the protocol hash a study stores (sha256_hex). Written for the haptic loop's thread: no
// allocation, no locks, no exceptions; the state is a plain value, so a
// state that has absorbed a prefix (HMAC's padded key) is saved by copying
// it and resumed per message.
//
//   Sha256 h;  h.update(a);  h.update(b);  Sha256::Digest d = h.finish();
//   == Sha256::hash(a + b)

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace hapticlab {

class Sha256 {
 public:
  static constexpr std::size_t kDigestBytes = 32;
  static constexpr std::size_t kBlockBytes = 64;
  using Digest = std::array<std::byte, kDigestBytes>;

  Sha256() noexcept = default;

  // Absorbs `data` (any length, in as many calls as convenient).
  void update(std::span<const std::byte> data) noexcept;
  // Pads, returns the digest and leaves the object spent: update() or
  // finish() after it give meaningless results until it is assigned anew.
  Digest finish() noexcept;

  static Digest hash(std::span<const std::byte> data) noexcept;

 private:
  void compress(const std::byte* block) noexcept;

  // H(0): the first 32 bits of the fractional parts of the square roots of
  // the first 8 primes (FIPS 180-4, 5.3.3).
  std::array<std::uint32_t, 8> state_{0x6a09e667u, 0xbb67ae85u, 0x3c6ef372u, 0xa54ff53au,
                                      0x510e527fu, 0x9b05688cu, 0x1f83d9abu, 0x5be0cd19u};
  std::array<std::byte, kBlockBytes> pending_{};  // bytes of an incomplete block
  std::size_t pending_bytes_ = 0;
  std::uint64_t total_bytes_ = 0;
};

// Lower-case hex of the SHA-256 of `text` (64 characters): the protocol
// hash a study stores, and the keys of stored plans. Allocates.
std::string sha256_hex(std::string_view text);

}  // namespace hapticlab
