#pragma once
// SplitMix64 (Steele, Lea & Flood 2014): a fully specified 64-bit generator,
// so a bootstrap run is reproducible from its seed on any compiler and
// standard library (std::uniform_int_distribution is not: its algorithm is
// implementation-defined).
#include <cstdint>

namespace hapticlab::analysis {

class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}

  std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ULL;
    std::uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }

  // Uniform integer in [0, bound), bound >= 1, by rejection: draws below
  // 2⁶⁴ mod bound are discarded so every residue is equally likely.
  // Integer arithmetic only.
  std::uint64_t below(std::uint64_t bound);

 private:
  std::uint64_t state_;
};

}  // namespace hapticlab::analysis
