#pragma once
// A fully specified random number generator for study schedules.
//
// A schedule must come out the same from the same seed on any machine,
// compiler and standard library, years later, so that a protocol file plus
// its seed is a complete record of who did what when. The standard library's
// engines are specified but its distributions and std::shuffle are not
// (libstdc++ and libc++ give different orders), so everything here is written
// out:
//
//   SplitMix64 (Steele, Lea, Flood 2014)     seed expansion and stream keys
//   xoshiro256** 1.0 (Blackman, Vigna 2018)  the generator
//   uniform_below(n): modulo with rejection  unbiased integer in [0, n)
//   shuffle(v): Fisher–Yates, from the back  uniform permutation
//
// Streams: `Rng::for_stream(seed, "schedule/S1")` keys an independent
// generator by a purpose string, so adding a participant, or drawing one
// more number for one purpose, never changes the draws of another.

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

namespace hapticlab::protocols {

// One SplitMix64 step: advances `state` by the golden-ratio increment and
// returns the mixed value (reference: prng.di.unimi.it/splitmix64.c).
constexpr std::uint64_t splitmix64_next(std::uint64_t& state) {
  state += 0x9E3779B97F4A7C15ULL;
  std::uint64_t z = state;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

// 64-bit FNV-1a of the bytes of `text` (offset basis 0xcbf29ce484222325,
// prime 0x100000001b3): turns a stream name into a key.
constexpr std::uint64_t fnv1a64(std::string_view text) {
  std::uint64_t h = 0xCBF29CE484222325ULL;
  for (char c : text) {
    h ^= static_cast<std::uint8_t>(c);
    h *= 0x100000001B3ULL;
  }
  return h;
}

class Rng {
 public:
  // State filled by four SplitMix64 outputs started at `seed`, as the
  // xoshiro authors recommend. SplitMix64 never outputs four zeros in a row,
  // so the forbidden all-zero state cannot occur.
  explicit constexpr Rng(std::uint64_t seed) {
    std::uint64_t sm = seed;
    for (auto& word : s_) word = splitmix64_next(sm);
  }

  // Independent stream for one purpose: seeded with
  // splitmix64_next(seed ^ fnv1a64(name)) (one step from that state).
  static constexpr Rng for_stream(std::uint64_t seed, std::string_view name) {
    std::uint64_t state = seed ^ fnv1a64(name);
    return Rng(splitmix64_next(state));
  }

  // Raw state, for the published test vector (state {1, 2, 3, 4}) only.
  static constexpr Rng from_state(std::uint64_t s0, std::uint64_t s1, std::uint64_t s2,
                                  std::uint64_t s3) {
    Rng r(0);
    r.s_[0] = s0;
    r.s_[1] = s1;
    r.s_[2] = s2;
    r.s_[3] = s3;
    return r;
  }

  // xoshiro256** next output (reference: prng.di.unimi.it/xoshiro256starstar.c).
  constexpr std::uint64_t next() {
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

  // Uniform integer in [0, n), n >= 1. Draws below 2^64 mod n are rejected
  // so every residue is equally likely; the expected number of draws is
  // below 2 for every n.
  constexpr std::uint64_t uniform_below(std::uint64_t n) {
    if (n <= 1) return 0;
    const std::uint64_t threshold = (0 - n) % n;  // == 2^64 mod n
    for (;;) {
      const std::uint64_t x = next();
      if (x >= threshold) return x % n;
    }
  }

  // A fair coin: the top bit of one draw.
  constexpr bool coin() { return (next() >> 63) != 0; }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) {
    return (x << k) | (x >> (64 - k));
  }

  std::uint64_t s_[4]{};
};

// Fisher–Yates: for i = n-1 down to 1, swap v[i] with v[uniform_below(i+1)].
// Every permutation equally likely; consumes exactly n-1 uniform draws.
template <typename T>
void shuffle(std::vector<T>& v, Rng& rng) {
  for (std::size_t i = v.size(); i > 1; --i) {
    const std::size_t j = static_cast<std::size_t>(rng.uniform_below(i));
    using std::swap;
    swap(v[i - 1], v[j]);
  }
}

}  // namespace hapticlab::protocols
