// Format 3's preconditioning of a chunk's body (chunk_body.h): per-update
// channels as differences of their bit patterns, in bit planes, and back.
#include <bit>

#include "db/chunk_body.h"

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace hapticlab::db::chunk {

// The channels of a format-1 body of `n` updates; `end` (if given) gets the
// offset just past the last one.
std::array<Segment, kChunkChannels> segments(std::span<std::byte> body, std::size_t n, std::size_t* end) {
  std::array<Segment, kChunkChannels> out;
  std::size_t pos = 0;
  const auto need = [&](std::size_t bytes) {
    if (bytes > body.size() - pos) throw ChunkError(ChunkError::Kind::kStructure, "blob too short for its count");
  };
  for (std::size_t c = 0; c < kChunkChannels; ++c) {
    need(1);
    Segment& g = out[c];
    g.tag = std::to_integer<std::uint8_t>(body[pos++]);
    g.width = static_cast<std::size_t>(channel_bytes(c));
    if (g.tag != kPerUpdate && g.tag != kConstant && !(g.tag == kRunningSum && c == 1))
      throw ChunkError(ChunkError::Kind::kStructure,
                       std::string("channel ") + kChannelNames[c] + " has unknown tag " + std::to_string(g.tag));
    const std::size_t bytes = g.tag == kPerUpdate ? n * g.width : g.width;
    need(bytes);
    g.values = body.data() + pos;
    pos += bytes;
  }
  if (end != nullptr) *end = pos;
  return out;
}


// A format-1 body of `n` updates that holds exactly its channels. Returns
// the channels' layout; throws ChunkError (kStructure) otherwise.
std::array<Segment, kChunkChannels> exact_segments(std::span<std::byte> body, std::size_t n) {
  std::size_t end = 0;
  const std::array<Segment, kChunkChannels> seg = segments(body, n, &end);
  if (end != body.size())
    throw structure(std::to_string(body.size()) + " bytes, more than " + std::to_string(n) + " samples use");
  return seg;
}

namespace {

// Values <-> bit planes. The first m = n - n % 8 values of W bytes become
// 8 * W planes of m / 8 bytes: plane k holds bit k % 8
// of byte k / 8 of every value, value i's at bit i % 8 of the plane's byte
// i / 8. The last n % 8 values follow as they are. Differences of a smooth
// signal share their high bits (zero, or all ones when negative), so most
// planes are runs of one byte; a byte plane would mix them with the noisy
// low bits (about 10 % smaller on the demo study, BENCHMARKS.md).
//
// 8 values x 8 bits of one byte as an 8 x 8 bit matrix (row r = value r's
// byte, in the uint64's byte r) transposed: row c = bit c of each value.
inline std::uint64_t transpose8x8(std::uint64_t x) noexcept {
  std::uint64_t t = (x ^ (x >> 7)) & 0x00AA00AA00AA00AAull;
  x ^= t ^ (t << 7);
  t = (x ^ (x >> 14)) & 0x0000CCCC0000CCCCull;
  x ^= t ^ (t << 14);
  t = (x ^ (x >> 28)) & 0x00000000F0F0F0F0ull;
  x ^= t ^ (t << 28);
  return x;
}

// 8 x 8 bytes transposed: byte c of x[r] and byte r of x[c] trade places.
// Blocks first (the 4 x 4 corners, then 2 x 2, then single bytes), each
// swap a masked XOR, as transpose8x8 does for bits. Spelled out and always
// inlined (GCC kept it a call, 6 % of the encoder), so the eight words stay
// in registers.
[[gnu::always_inline]] inline void swap_masked(std::uint64_t& a, std::uint64_t& b, int shift, std::uint64_t mask) noexcept {
  const std::uint64_t t = ((a >> shift) ^ b) & mask;
  a ^= t << shift;
  b ^= t;
}
[[gnu::always_inline]] inline void transpose_bytes8x8(std::array<std::uint64_t, 8>& x) noexcept {
  constexpr std::uint64_t k4 = 0x00000000FFFFFFFFull, k2 = 0x0000FFFF0000FFFFull, k1 = 0x00FF00FF00FF00FFull;
  swap_masked(x[0], x[4], 32, k4);
  swap_masked(x[1], x[5], 32, k4);
  swap_masked(x[2], x[6], 32, k4);
  swap_masked(x[3], x[7], 32, k4);
  swap_masked(x[0], x[2], 16, k2);
  swap_masked(x[1], x[3], 16, k2);
  swap_masked(x[4], x[6], 16, k2);
  swap_masked(x[5], x[7], 16, k2);
  swap_masked(x[0], x[1], 8, k1);
  swap_masked(x[2], x[3], 8, k1);
  swap_masked(x[4], x[5], 8, k1);
  swap_masked(x[6], x[7], 8, k1);
}

// The 8 bytes of `word` to p[0], p[stride], ..., p[7 * stride], low byte
// first, and back: one byte of each of 8 consecutive planes. Unrolled by
// hand (GCC at -O2 keeps the loop, and it dominated the encoder).
inline void scatter8(std::byte* p, std::size_t stride, std::uint64_t word) noexcept {
  p[0] = static_cast<std::byte>(word);
  p[stride] = static_cast<std::byte>(word >> 8);
  p[2 * stride] = static_cast<std::byte>(word >> 16);
  p[3 * stride] = static_cast<std::byte>(word >> 24);
  p[4 * stride] = static_cast<std::byte>(word >> 32);
  p[5 * stride] = static_cast<std::byte>(word >> 40);
  p[6 * stride] = static_cast<std::byte>(word >> 48);
  p[7 * stride] = static_cast<std::byte>(word >> 56);
}
inline std::uint64_t gather8(const std::byte* p, std::size_t stride) noexcept {
  const auto at = [&](std::size_t k) { return std::uint64_t{std::to_integer<std::uint8_t>(p[k * stride])} << (8 * k); };
  return at(0) | at(1) | at(2) | at(3) | at(4) | at(5) | at(6) | at(7);
}

#if defined(__SSE2__)
// Planes -> values for groups g .. g + 15 (`half`: g .. g + 7) at once,
// into out: most of analyze's decoding, 2.5x faster than a group at a time
// (an x86-64 baseline instruction set, so no run-time choice). Per byte b
// of the values: the 16 bytes of each of planes 8b .. 8b + 7 at g are
// byte-transposed with unpacks, so that one vector holds, for two
// consecutive groups, each plane's byte (plane s at byte s of its half);
// then bit j of every byte, collected by movemask (the top bit, after
// shifting j to it), is byte b of value 8 (g + k) + j for both groups.
template <std::size_t W>
[[gnu::always_inline]] inline void planes_to_values_sse2(const std::byte* v, std::size_t groups, std::size_t g,
                                                         std::byte* out, bool half) noexcept {
  for (std::size_t b = 0; b < W; ++b) {
    __m128i a[8];  // (std::array<__m128i> drops the vector type's attributes: a GCC warning)
    for (std::size_t s = 0; s < 8; ++s) {
      const auto* p = reinterpret_cast<const __m128i*>(v + (8 * b + s) * groups + g);
      a[s] = half ? _mm_loadl_epi64(p) : _mm_loadu_si128(p);
    }
    const __m128i t0 = _mm_unpacklo_epi8(a[0], a[1]), t1 = _mm_unpackhi_epi8(a[0], a[1]);
    const __m128i t2 = _mm_unpacklo_epi8(a[2], a[3]), t3 = _mm_unpackhi_epi8(a[2], a[3]);
    const __m128i t4 = _mm_unpacklo_epi8(a[4], a[5]), t5 = _mm_unpackhi_epi8(a[4], a[5]);
    const __m128i t6 = _mm_unpacklo_epi8(a[6], a[7]), t7 = _mm_unpackhi_epi8(a[6], a[7]);
    const __m128i u0 = _mm_unpacklo_epi16(t0, t2), u1 = _mm_unpackhi_epi16(t0, t2);
    const __m128i u2 = _mm_unpacklo_epi16(t1, t3), u3 = _mm_unpackhi_epi16(t1, t3);
    const __m128i u4 = _mm_unpacklo_epi16(t4, t6), u5 = _mm_unpackhi_epi16(t4, t6);
    const __m128i u6 = _mm_unpacklo_epi16(t5, t7), u7 = _mm_unpackhi_epi16(t5, t7);
    // x[k]: groups g + 2k (bytes 0..7, plane s at byte s) and g + 2k + 1 (8..15).
    const __m128i x[8] = {_mm_unpacklo_epi32(u0, u4), _mm_unpackhi_epi32(u0, u4),
                          _mm_unpacklo_epi32(u1, u5), _mm_unpackhi_epi32(u1, u5),
                          _mm_unpacklo_epi32(u2, u6), _mm_unpackhi_epi32(u2, u6),
                          _mm_unpacklo_epi32(u3, u7), _mm_unpackhi_epi32(u3, u7)};
    const std::size_t pairs = half ? 4 : 8;
    for (std::size_t k = 0; k < pairs; ++k) {
      __m128i y = x[k];
      std::byte* const first = out + 8 * (g + 2 * k) * W + b;
      std::byte* const second = first + 8 * W;
      for (std::size_t j = 8; j-- > 0;) {
        const auto m = static_cast<unsigned>(_mm_movemask_epi8(y));
        first[j * W] = static_cast<std::byte>(m);
        second[j * W] = static_cast<std::byte>(m >> 8);
        y = _mm_add_epi8(y, y);  // next lower bit to the top
      }
    }
  }
}

// 4-byte values, groups g .. g + 31, with AVX2 where the CPU has it (chosen
// at run time: the build targets the x86-64 baseline). The SSE2 path's
// stores of one byte per value byte bound it (a byte store per output
// byte); here each value is one 32-bit store. Per byte b, the unpacks
// (within each 128-bit lane: lane 0 groups g .. g + 15, lane 1 g + 16 ..
// g + 31) leave x[b][k] = planes 8b .. 8b + 7 of groups g + 2k, g + 2k + 1,
// g + 16 + 2k, g + 17 + 2k, a quadword each. A 4 x 4 quadword transpose of
// x[0..3][k] gives, per group, its 32 planes' bytes in one vector (plane p
// at byte p), so bit j of every byte, collected by movemask, is value j of
// the group whole: bit p of the mask is bit p % 8 of its byte p / 8.
[[gnu::target("avx2")]] void planes_to_values4_avx2(const std::byte* v, std::size_t groups, std::size_t g,
                                                    std::byte* out) noexcept {
  constexpr std::size_t W = 4;
  __m256i x[W][8];
  for (std::size_t b = 0; b < W; ++b) {
    __m256i a[8];
    for (std::size_t s = 0; s < 8; ++s)
      a[s] = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(v + (8 * b + s) * groups + g));
    const __m256i t0 = _mm256_unpacklo_epi8(a[0], a[1]), t1 = _mm256_unpackhi_epi8(a[0], a[1]);
    const __m256i t2 = _mm256_unpacklo_epi8(a[2], a[3]), t3 = _mm256_unpackhi_epi8(a[2], a[3]);
    const __m256i t4 = _mm256_unpacklo_epi8(a[4], a[5]), t5 = _mm256_unpackhi_epi8(a[4], a[5]);
    const __m256i t6 = _mm256_unpacklo_epi8(a[6], a[7]), t7 = _mm256_unpackhi_epi8(a[6], a[7]);
    const __m256i u0 = _mm256_unpacklo_epi16(t0, t2), u1 = _mm256_unpackhi_epi16(t0, t2);
    const __m256i u2 = _mm256_unpacklo_epi16(t1, t3), u3 = _mm256_unpackhi_epi16(t1, t3);
    const __m256i u4 = _mm256_unpacklo_epi16(t4, t6), u5 = _mm256_unpackhi_epi16(t4, t6);
    const __m256i u6 = _mm256_unpacklo_epi16(t5, t7), u7 = _mm256_unpackhi_epi16(t5, t7);
    x[b][0] = _mm256_unpacklo_epi32(u0, u4);
    x[b][1] = _mm256_unpackhi_epi32(u0, u4);
    x[b][2] = _mm256_unpacklo_epi32(u1, u5);
    x[b][3] = _mm256_unpackhi_epi32(u1, u5);
    x[b][4] = _mm256_unpacklo_epi32(u2, u6);
    x[b][5] = _mm256_unpackhi_epi32(u2, u6);
    x[b][6] = _mm256_unpacklo_epi32(u3, u7);
    x[b][7] = _mm256_unpackhi_epi32(u3, u7);
  }
  for (std::size_t k = 0; k < 8; ++k) {
    const __m256i lo01 = _mm256_unpacklo_epi64(x[0][k], x[1][k]), lo23 = _mm256_unpacklo_epi64(x[2][k], x[3][k]);
    const __m256i hi01 = _mm256_unpackhi_epi64(x[0][k], x[1][k]), hi23 = _mm256_unpackhi_epi64(x[2][k], x[3][k]);
    __m256i planes[4] = {_mm256_permute2x128_si256(lo01, lo23, 0x20), _mm256_permute2x128_si256(hi01, hi23, 0x20),
                         _mm256_permute2x128_si256(lo01, lo23, 0x31), _mm256_permute2x128_si256(hi01, hi23, 0x31)};
    std::byte* const o[4] = {out + 8 * (g + 2 * k) * W, out + 8 * (g + 2 * k + 1) * W, out + 8 * (g + 16 + 2 * k) * W,
                             out + 8 * (g + 17 + 2 * k) * W};
    for (std::size_t j = 8; j-- > 0;) {
      for (std::size_t q = 0; q < 4; ++q) {
        const auto m = static_cast<std::uint32_t>(_mm256_movemask_epi8(planes[q]));
        std::memcpy(o[q] + j * W, &m, W);
        planes[q] = _mm256_add_epi8(planes[q], planes[q]);  // next lower bit to the top
      }
    }
  }
}

const bool kHaveAvx2 = [] {
  __builtin_cpu_init();  // a static initializer may run before libgcc's own
  return __builtin_cpu_supports("avx2") != 0;
}();
#endif

// Bit planes of n values of W bytes at v: `to_planes` makes them in
// place; false undoes them into `scratch` (n * W bytes). Per group of 8
// values: their bytes transposed (word b = byte b of each value), then each
// word's bits (transpose8x8), whose 8 bytes are the group's byte in planes
// 8b..8b+7. The group's values are loaded and stored whole, not byte by
// byte: this runs on every chunk the writer thread stores and every chunk
// analyze reads.
template <std::size_t W>
void bit_planes(std::byte* v, std::size_t n, bool to_planes, std::vector<std::byte>& scratch) {
  static_assert(W == 4 || W == 8);
  const std::size_t groups = n / 8;
  scratch.resize(n * W);
  std::byte* const out = scratch.data();
  for (std::size_t g = 0; g < groups; ++g) {
    std::array<std::uint64_t, 8> x{};
    if (to_planes) {
      for (std::size_t r = 0; r < 8; ++r) std::memcpy(&x[r], v + (8 * g + r) * W, W);
      transpose_bytes8x8(x);
      for (std::size_t b = 0; b < W; ++b) scatter8(out + 8 * b * groups + g, groups, transpose8x8(x[b]));
    } else {
#if defined(__SSE2__)
      // 32 groups at once with AVX2 (4-byte values), then 16 and 8 with SSE2
      // (planes_to_values_sse2), the rest one at a time.
      if (W == 4 && kHaveAvx2 && g + 32 <= groups) {
        planes_to_values4_avx2(v, groups, g, out);
        g += 31;
        continue;
      }
      if (g + 16 <= groups) {
        planes_to_values_sse2<W>(v, groups, g, out, false);
        g += 15;
        continue;
      }
      if (g + 8 <= groups) {
        planes_to_values_sse2<W>(v, groups, g, out, true);
        g += 7;
        continue;
      }
#endif
      // transpose8x8 is its own inverse.
      for (std::size_t b = 0; b < W; ++b) x[b] = transpose8x8(gather8(v + 8 * b * groups + g, groups));
      transpose_bytes8x8(x);
      for (std::size_t r = 0; r < 8; ++r) std::memcpy(out + (8 * g + r) * W, &x[r], W);
    }
  }
  std::memcpy(out + groups * 8 * W, v + groups * 8 * W, (n - groups * 8) * W);
  // Undoing, the caller takes the values from scratch (with its sums, in
  // the same pass); making planes, they go back in place.
  if (to_planes) std::memcpy(v, out, n * W);
}

// Differences modulo 2^bits, in place (first value kept), and their sums.
template <typename U>
void differences(std::byte* v, std::size_t n) {
  U prev = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const U x = load<U>(v + i * sizeof(U));
    const U d = static_cast<U>(x - prev);
    prev = x;
    std::memcpy(v + i * sizeof(U), &d, sizeof d);
  }
}
// The running sums of the differences at `from`, to `to`.
template <typename U>
void sums(const std::byte* from, std::byte* to, std::size_t n) {
  U prev = 0;
  for (std::size_t i = 0; i < n; ++i) {
    prev = static_cast<U>(prev + load<U>(from + i * sizeof(U)));
    std::memcpy(to + i * sizeof(U), &prev, sizeof prev);
  }
}

// dt[i]'s bits XOR those of t[i] - t[i-1] (i >= 1), in place, for a chunk
// whose t_s is stored per update (the wall clock's: where t[i-1] + dt[i]
// is not t[i] to the bit): a clock's dt is its t's difference, give or
// take a rounding, so what is left is zero or a few low bits. `t` holds
// the decoded t_s values.
void period_residuals(std::byte* dt, const std::byte* t, std::size_t n) {
  for (std::size_t i = 1; i < n; ++i) {
    const double step = std::bit_cast<double>(load<std::uint64_t>(t + i * 8)) -
                        std::bit_cast<double>(load<std::uint64_t>(t + (i - 1) * 8));
    const std::uint64_t x = load<std::uint64_t>(dt + i * 8) ^ std::bit_cast<std::uint64_t>(step);
    std::memcpy(dt + i * 8, &x, 8);
  }
}

}  // namespace

// `only`: undoing (forward false), the channels to restore; the others are
// left preconditioned (a reader that projects never reads them).
void precondition(std::span<std::byte> body, std::size_t n, bool forward, std::vector<std::byte>& scratch,
                  ChannelSet only) {
  const std::array<Segment, kChunkChannels> seg = segments(body, n);
  constexpr std::size_t kPeriod = 0, kTime = 1;
  // dt as residuals of t's differences: t must be as stored when they are
  // made, and restored before they are undone.
  const bool residual_dt = seg[kPeriod].tag == kPerUpdate && seg[kTime].tag == kPerUpdate;
  if (forward && residual_dt) period_residuals(seg[kPeriod].values, seg[kTime].values, n);
  for (std::size_t c = 0; c < kChunkChannels; ++c) {
    const Segment& g = seg[c];
    if (g.tag != kPerUpdate || g.width == 1) continue;
    if (!forward && (only & (ChannelSet{1} << c)) == 0) continue;
    // Differences for every channel but a residual dt; planes for all.
    const bool differenced = !(c == kPeriod && residual_dt);
    const auto planes = [&](bool to_planes) {
      if (g.width == 4) bit_planes<4>(g.values, n, to_planes, scratch);
      else bit_planes<8>(g.values, n, to_planes, scratch);
    };
    if (forward) {
      if (differenced) g.width == 4 ? differences<std::uint32_t>(g.values, n) : differences<std::uint64_t>(g.values, n);
      planes(true);
    } else {
      planes(false);  // the differences, in scratch
      if (!differenced) std::memcpy(g.values, scratch.data(), n * g.width);
      else if (g.width == 4) sums<std::uint32_t>(scratch.data(), g.values, n);
      else sums<std::uint64_t>(scratch.data(), g.values, n);
    }
  }
  if (!forward && residual_dt && (only & (ChannelSet{1} << kPeriod)) != 0)
    period_residuals(seg[kPeriod].values, seg[kTime].values, n);
}

}  // namespace hapticlab::db::chunk
