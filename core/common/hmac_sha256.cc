#include "core/common/hmac_sha256.h"

#include <array>
#include <cstring>

namespace hapticlab {

HmacSha256::HmacSha256(std::span<const std::byte> key) noexcept {
  std::array<std::byte, Sha256::kBlockBytes> k0{};
  if (key.size() > Sha256::kBlockBytes) {
    const Sha256::Digest d = Sha256::hash(key);
    std::memcpy(k0.data(), d.data(), d.size());
  } else if (!key.empty()) {
    std::memcpy(k0.data(), key.data(), key.size());
  }
  std::array<std::byte, Sha256::kBlockBytes> pad;
  for (std::size_t i = 0; i < pad.size(); ++i) pad[i] = k0[i] ^ std::byte{0x36};
  inner_.update(pad);
  for (std::size_t i = 0; i < pad.size(); ++i) pad[i] = k0[i] ^ std::byte{0x5c};
  outer_.update(pad);
}

Sha256::Digest HmacSha256::mac(std::span<const std::byte> message) const noexcept {
  Sha256 inner = inner_;
  inner.update(message);
  const Sha256::Digest inner_digest = inner.finish();
  Sha256 outer = outer_;
  outer.update(inner_digest);
  return outer.finish();
}

bool HmacSha256::verify(std::span<const std::byte> message, std::span<const std::byte> tag) const noexcept {
  if (tag.empty() || tag.size() > Sha256::kDigestBytes) return false;
  const Sha256::Digest expected = mac(message);
  std::byte difference{0};
  for (std::size_t i = 0; i < tag.size(); ++i) difference |= expected[i] ^ tag[i];
  return difference == std::byte{0};
}

}  // namespace hapticlab
