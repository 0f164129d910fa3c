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
//
// The generator itself is core/common/random.h's, shared with the simulation
// and the bootstrap; this file adds the stream keys and the shuffle.

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "core/common/random.h"

namespace hapticlab::protocols {

// One SplitMix64 step (core/common/random.h).
constexpr std::uint64_t splitmix64_next(std::uint64_t& state) { return splitmix64(state); }

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
  // State filled by four SplitMix64 outputs started at `seed`.
  explicit constexpr Rng(std::uint64_t seed) : core_(seed) {}

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
    r.core_ = Xoshiro256StarStar::from_state(s0, s1, s2, s3);
    return r;
  }

  // xoshiro256** next output.
  constexpr std::uint64_t next() { return core_.next(); }

  // Uniform integer in [0, n), n >= 1; n <= 1 gives 0 without a draw, which
  // every schedule so far relies on.
  constexpr std::uint64_t uniform_below(std::uint64_t n) {
    if (n <= 1) return 0;
    return hapticlab::uniform_below(core_, n);
  }

  // A fair coin: the top bit of one draw.
  constexpr bool coin() { return (next() >> 63) != 0; }

 private:
  Xoshiro256StarStar core_;
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
