#pragma once
// SHA-256 (FIPS 180-4), for the protocol hash stored with each study: the
// hash says, years later, exactly which protocol text a study ran. Written
// here because no dependency of the project provides it; tested against the
// FIPS 180 example vectors (tests/db/sha256_test.cc).

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace hapticlab::db {

class Sha256 {
 public:
  using Digest = std::array<std::uint8_t, 32>;

  Sha256() noexcept;
  // Feed any number of times, then digest() once.
  void update(const void* data, std::size_t size) noexcept;
  void update(std::string_view text) noexcept { update(text.data(), text.size()); }
  Digest digest() noexcept;

 private:
  void compress(const std::uint8_t* block) noexcept;

  std::array<std::uint32_t, 8> state_;
  std::array<std::uint8_t, 64> buffer_{};
  std::size_t buffered_ = 0;
  std::uint64_t total_bytes_ = 0;
};

// Lower-case hex of the SHA-256 of `text` (64 characters).
std::string sha256_hex(std::string_view text);

}  // namespace hapticlab::db
