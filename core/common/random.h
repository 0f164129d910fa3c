#pragma once
// The one fully specified random number generator of HapticLab, so that a
// seed gives the same simulation, schedule and bootstrap on every machine and
// standard library (std::uniform_*_distribution and std::shuffle are
// implementation-defined). The study schedules (protocols/rng.h) and the
// bootstrap (analysis/stats) use these same functions.
//
// SplitMix64 (Steele, Lea & Flood 2014) expands a 64-bit seed and, on its
// own, drives the bootstrap; xoshiro256** 1.0 (Blackman & Vigna 2018)
// produces the simulation and schedule streams. Integers in [0, n) come from
// uniform_below (modulo with rejection, no bias); doubles are the top 53 bits
// scaled to [0, 1); normals use the polar Box–Muller method, whose result
// depends only on IEEE arithmetic and std::log/std::sqrt.

#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace hapticlab {

// One step of SplitMix64: advances `state` by the golden-ratio increment and
// returns the mixed value (reference: prng.di.unimi.it/splitmix64.c).
constexpr std::uint64_t splitmix64(std::uint64_t& state) noexcept {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Uniform integer in [0, bound) from gen.next() draws, bound >= 1. Draws
// below 2^64 mod bound are rejected so every residue is equally likely; the
// expected number of draws is below 2 for every bound, and exactly one draw
// is used for bound 1.
template <typename Generator>
constexpr std::uint64_t uniform_below(Generator& gen, std::uint64_t bound) noexcept {
  const std::uint64_t threshold = (0 - bound) % bound;  // == 2^64 mod bound
  for (;;) {
    const std::uint64_t r = gen.next();
    if (r >= threshold) return r % bound;
  }
}

// SplitMix64 as a stream of its own (the bootstrap's generator).
class SplitMix64 {
 public:
  explicit constexpr SplitMix64(std::uint64_t seed) noexcept : state_(seed) {}

  constexpr std::uint64_t next() noexcept { return splitmix64(state_); }

  // Uniform integer in [0, bound); throws std::invalid_argument for bound 0,
  // which has no value to give (a caller's bug).
  constexpr std::uint64_t below(std::uint64_t bound) {
    if (bound == 0) throw std::invalid_argument("SplitMix64::below(): bound must be >= 1");
    return uniform_below(*this, bound);
  }

 private:
  std::uint64_t state_;
};

// xoshiro256** 1.0 (reference: prng.di.unimi.it/xoshiro256starstar.c).
class Xoshiro256StarStar {
 public:
  // State filled by four SplitMix64 outputs started at `seed`, as the
  // xoshiro authors recommend. SplitMix64 never outputs four zeros in a row,
  // so the forbidden all-zero state cannot occur.
  explicit constexpr Xoshiro256StarStar(std::uint64_t seed = 0) noexcept {
    std::uint64_t sm = seed;
    for (auto& word : s_) word = splitmix64(sm);
  }

  // Raw state, for published test vectors.
  static constexpr Xoshiro256StarStar from_state(std::uint64_t s0, std::uint64_t s1,
                                                 std::uint64_t s2, std::uint64_t s3) noexcept {
    Xoshiro256StarStar x;
    x.s_[0] = s0;
    x.s_[1] = s1;
    x.s_[2] = s2;
    x.s_[3] = s3;
    return x;
  }

  constexpr std::uint64_t next() noexcept {
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

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) noexcept {
    return (x << k) | (x >> (64 - k));
  }
  std::uint64_t s_[4]{};
};

class Random {
 public:
  explicit constexpr Random(std::uint64_t seed = 0) noexcept { reseed(seed); }

  constexpr void reseed(std::uint64_t seed) noexcept {
    core_ = Xoshiro256StarStar(seed);
    has_spare_normal_ = false;
  }

  // A generator for an independent sub-stream (a participant, a trial, a
  // task layout), derived from this one's seed material and a label, so that
  // adding draws to one stream never shifts another.
  static constexpr Random derive(std::uint64_t seed, std::uint64_t label) noexcept {
    std::uint64_t sm = seed ^ (label * 0xD1B54A32D192ED03ull);
    return Random(splitmix64(sm));
  }

  constexpr std::uint64_t next_u64() noexcept { return core_.next(); }

  // Uniform integer in [0, bound), bound > 0.
  constexpr std::uint64_t below(std::uint64_t bound) noexcept { return uniform_below(core_, bound); }

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
  Xoshiro256StarStar core_;
  double spare_normal_ = 0.0;
  bool has_spare_normal_ = false;
};

}  // namespace hapticlab
