#pragma once
// A fully specified random number generator, so that a seed gives the same
// simulation, schedule and bootstrap on every machine and standard library
// (std::uniform_*_distribution and std::shuffle are implementation-defined).
//
// SplitMix64 (Steele, Lea & Flood 2014) expands a 64-bit seed; xoshiro256**
// (Blackman & Vigna 2018) produces the stream. Doubles are the top 53 bits
// scaled to [0, 1); normals use the polar Box–Muller method, whose result
// depends only on IEEE arithmetic and std::log/std::sqrt.

#include <cmath>
#include <cstdint>

namespace hapticlab {

// One step of SplitMix64: advances `state` and returns the next output.
constexpr std::uint64_t splitmix64(std::uint64_t& state) noexcept {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

class Random {
 public:
  explicit constexpr Random(std::uint64_t seed = 0) noexcept { reseed(seed); }

  constexpr void reseed(std::uint64_t seed) noexcept {
    std::uint64_t sm = seed;
    for (auto& word : s_) word = splitmix64(sm);
    has_spare_normal_ = false;
  }

  // A generator for an independent sub-stream (a participant, a trial, a
  // task layout), derived from this one's seed material and a label, so that
  // adding draws to one stream never shifts another.
  static constexpr Random derive(std::uint64_t seed, std::uint64_t label) noexcept {
    std::uint64_t sm = seed ^ (label * 0xD1B54A32D192ED03ull);
    return Random(splitmix64(sm));
  }

  constexpr std::uint64_t next_u64() noexcept {
    const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }

  // Uniform integer in [0, bound), bound > 0, without modulo bias (rejection).
  constexpr std::uint64_t below(std::uint64_t bound) noexcept {
    const std::uint64_t threshold = (0 - bound) % bound;  // 2^64 mod bound
    for (;;) {
      const std::uint64_t r = next_u64();
      if (r >= threshold) return r % bound;
    }
  }

  // Uniform in [0, 1).
  constexpr double uniform() noexcept {
    return static_cast<double>(next_u64() >> 11) * 0x1.0p-53;
  }
  constexpr double uniform(double lo, double hi) noexcept { return lo + (hi - lo) * uniform(); }

  // Standard normal (polar Box–Muller).
  double normal() noexcept {
    if (has_spare_normal_) {
      has_spare_normal_ = false;
      return spare_normal_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_normal_ = v * f;
    has_spare_normal_ = true;
    return u * f;
  }
  double normal(double mean, double sd) noexcept { return mean + sd * normal(); }
  // Log-normal factor with median 1 and the given log-standard deviation:
  // for traits and trial-to-trial variation that scale a quantity.
  double lognormal_factor(double log_sd) noexcept { return std::exp(log_sd * normal()); }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) noexcept {
    return (x << k) | (x >> (64 - k));
  }
  std::uint64_t s_[4]{};
  double spare_normal_ = 0.0;
  bool has_spare_normal_ = false;
};

}  // namespace hapticlab
