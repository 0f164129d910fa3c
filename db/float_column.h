#pragma once
// A column of float32 values read in place, widened to double: how the
// chunk decoder (sample_codec.h, chunk_reader.h) hands a channel to a
// reader without copying it. Value i is at `values` + i * `stride_bytes`, little-endian
// (stride 0: one value for every update, a channel stored once).

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace hapticlab::db {

struct FloatColumn {
  const std::byte* values = nullptr;
  std::size_t stride_bytes = 0;
  // Widening a float to double is exact.
  double operator[](std::size_t i) const noexcept {
    std::uint32_t bits;
    std::memcpy(&bits, values + i * stride_bytes, sizeof bits);
    return double{std::bit_cast<float>(bits)};
  }
};

}  // namespace hapticlab::db
