#pragma once
// HMAC-SHA-256 (RFC 2104 with FIPS 180-4's SHA-256; test vectors RFC 4231):
//
//   HMAC(K, m) = H((K0 ^ opad) || H((K0 ^ ipad) || m))
//
// K0 is the key padded with zeros to the 64-byte block (a longer key is
// hashed first). The two padded-key blocks are absorbed once, in the
// constructor; mac() copies those two states and hashes only the message
// and one outer block, without allocating: the UDP bridge runs it on the
// haptic loop's thread for every datagram. The empty key is a valid key
// (an unkeyed checksum, not an authenticator).

#include <cstddef>
#include <span>

#include "core/common/sha256.h"

namespace hapticlab {

class HmacSha256 {
 public:
  // The empty key.
  HmacSha256() noexcept : HmacSha256(std::span<const std::byte>{}) {}
  explicit HmacSha256(std::span<const std::byte> key) noexcept;

  Sha256::Digest mac(std::span<const std::byte> message) const noexcept;
  // Whether `tag` (1..32 bytes: a MAC truncated to its first tag.size()
  // bytes) is the MAC of `message`. Compares in time independent of where
  // the first difference is, so the answer's timing reveals nothing of
  // the right tag.
  bool verify(std::span<const std::byte> message, std::span<const std::byte> tag) const noexcept;

 private:
  Sha256 inner_;  // has absorbed K0 ^ ipad
  Sha256 outer_;  // has absorbed K0 ^ opad
};

}  // namespace hapticlab
