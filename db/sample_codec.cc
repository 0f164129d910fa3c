#include "db/sample_codec.h"

#include "core/loop/sample_channels.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include <zstd.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace hapticlab::db {

// One list for every sample table (core/loop/sample_channels.h).
const std::array<const char*, kChunkChannels> kChannelNames = kSampleChannelNames;

namespace {

// 8 bytes little-endian of `v` at `out`.
void put_le64(std::byte* out, std::uint64_t v) noexcept {
  for (int i = 0; i < 8; ++i) out[i] = static_cast<std::byte>(v >> (8 * i));
}

// The checksum of a chunk (schema 7 on): where it belongs -- its row's
// trial, instrument, first tick and count -- then the blob without the
// checksum bytes (format byte, body).
std::uint32_t chunk_crc(const ChunkPlace& place, std::byte format, std::span<const std::byte> body) noexcept {
  std::array<std::byte, 33> head{};
  put_le64(&head[0], static_cast<std::uint64_t>(place.trial_id));
  put_le64(&head[8], static_cast<std::uint64_t>(place.instrument));
  put_le64(&head[16], place.first_tick);
  put_le64(&head[24], place.count);
  head[32] = format;
  return crc32c(crc32c(0, head), body);
}

// Schemas 4..6: the row's first tick and count only.
std::uint32_t schema6_crc(std::uint64_t first_tick, std::uint64_t count, std::byte format,
                          std::span<const std::byte> body) noexcept {
  std::array<std::byte, 17> head{};
  put_le64(&head[0], first_tick);
  put_le64(&head[8], count);
  head[16] = format;
  return crc32c(crc32c(0, head), body);
}

void put_crc(std::vector<std::byte>& blob, std::uint32_t crc) noexcept {
  for (int i = 0; i < 4; ++i) blob[static_cast<std::size_t>(1 + i)] = static_cast<std::byte>(crc >> (8 * i));
}

std::uint32_t stored_crc(std::span<const std::byte> blob) noexcept {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v |= std::uint32_t{std::to_integer<std::uint8_t>(blob[1 + i])} << (8 * i);
  return v;
}

std::string hex32(std::uint32_t v) {
  char buf[11];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}

enum Tag : std::uint8_t { kPerUpdate = 0, kConstant = 1, kRunningSum = 2 };

// Channels 2..24: the float32 ones, as pointers into InstrumentSample.
double* float_channel(InstrumentSample& s, std::size_t channel) noexcept {
  const std::size_t k = channel - 2;
  if (k < 5) return &s.raw_position[k];
  if (k < 8) return &s.degraded_position[k - 5];
  if (k < 11) return &s.tip_position_m[k - 8];
  if (k < 14) return &s.tip_velocity_m_per_s[k - 11];
  if (k < 17) return &s.ve_force_N[k - 14];
  if (k < 20) return &s.displayed_force_N[k - 17];
  return &s.joint_force[k - 20];
}
constexpr std::size_t kFirstFloat = 2, kEndFloat = 25;
constexpr std::size_t kEngineStatus = 25, kDeviceStatus = 26, kInContact = 27;

static_assert(std::endian::native == std::endian::little, "the chunk format is little-endian; memcpy assumes it");

}  // namespace

namespace {
// A double beyond float's range converts with undefined behaviour; such a
// value is stored as infinity of its sign. Inline here: the encoder calls
// it 23 times per update.
inline float stored_float(double value) noexcept {
  constexpr double kMax = std::numeric_limits<float>::max();
  if (value > kMax) return std::numeric_limits<float>::infinity();
  if (value < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(value);  // NaN and in-range values
}
}  // namespace

float to_stored_float(double value) noexcept { return stored_float(value); }

namespace {

constexpr std::size_t kNumFloat = kEndFloat - kFirstFloat;

// One update's float32 channels in blob order, as stored bit patterns.
// Spelled out (not looked up per channel) because the encoder runs this
// for every update on the logging rate's critical path.
inline void float_bits(const InstrumentSample& v, std::uint32_t* out) noexcept {
  std::size_t k = 0;
  const auto put = [&](double x) { out[k++] = std::bit_cast<std::uint32_t>(stored_float(x)); };
  for (double x : v.raw_position) put(x);
  for (double x : v.degraded_position) put(x);
  for (double x : v.tip_position_m) put(x);
  for (double x : v.tip_velocity_m_per_s) put(x);
  for (double x : v.ve_force_N) put(x);
  for (double x : v.displayed_force_N) put(x);
  for (double x : v.joint_force) put(x);
}

// Appends to a buffer sized for the worst case up front (the encoder is on
// the logging rate's critical path: no per-byte push_back).
class Writer {
 public:
  explicit Writer(std::size_t capacity) : out_(capacity) {}
  void byte(std::uint8_t v) noexcept { out_[pos_++] = static_cast<std::byte>(v); }
  // Little-endian, the low `Bytes` of `bits` (the memcpy relies on the
  // machine being little-endian, asserted above).
  template <int Bytes>
  void le(std::uint64_t bits) noexcept {
    std::memcpy(out_.data() + pos_, &bits, Bytes);
    pos_ += Bytes;
  }
  std::vector<std::byte> take() {
    out_.resize(pos_);
    return std::move(out_);
  }

 private:
  std::vector<std::byte> out_;
  std::size_t pos_ = 0;
};

// One channel from its values' stored bit patterns, update i's at
// bits[i * stride]: tag, then one value (all equal) or all of them.
template <int Bytes, typename Bits>
void put_bits(Writer& w, const Bits* bits, std::size_t n, std::size_t stride = 1) {
  bool constant = true;
  for (std::size_t i = 1; i < n && constant; ++i) constant = bits[i * stride] == bits[0];
  w.byte(constant ? kConstant : kPerUpdate);
  const std::size_t values = constant ? 1 : n;
  for (std::size_t i = 0; i < values; ++i) w.le<Bytes>(static_cast<std::uint64_t>(bits[i * stride]));
}

// Bytes per value of each channel, in blob order (t_s's running-sum tag
// is followed by one 8-byte value, like a constant).
constexpr int channel_bytes(std::size_t channel) noexcept {
  return channel < kFirstFloat ? 8 : channel == kInContact ? 1 : 4;
}

// Format 2's preconditioning of a format-1 body, in place (the layout is
// documented in sample_codec.h): per-update channels of 4 or 8 bytes become
// differences of consecutive bit patterns, in bit planes; when t_s is
// stored per update too, dt_s instead becomes its XOR with t's differences
// (period_residuals), in bit planes. Smooth signals then differ in their
// low bits only, and the high bit planes are long runs zstd compresses to
// almost nothing. Tags, constants and 1-byte channels
// are unchanged, so the inverse walks the same layout. `forward` false
// undoes it. Throws ChunkError (kStructure) for a body that does not hold
// `n` updates' worth of channels.
struct Segment {
  std::uint8_t tag = kConstant;
  std::byte* values = nullptr;  // the channel's first value
  std::size_t width = 0;        // bytes per value
};

// The channels of a format-1 body of `n` updates; `end` (if given) gets the
// offset just past the last one.
std::array<Segment, kChunkChannels> segments(std::span<std::byte> body, std::size_t n, std::size_t* end = nullptr) {
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

template <typename U>
U load(const std::byte* p) noexcept {
  U v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

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
#endif

// Bit planes of n values of W bytes at v, in place: `to_planes` makes
// them, false undoes it. Per group of 8 values: their bytes transposed
// (word b = byte b of each value), then each word's bits (transpose8x8),
// whose 8 bytes are the group's byte in planes 8b..8b+7. The group's values
// are loaded and stored whole, not byte by byte: this runs on every chunk
// the writer thread stores and every chunk analyze reads.
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
      // 16 (then 8) groups at once with SSE2 (planes_to_values_sse2), the
      // rest one at a time.
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
  std::memcpy(v, out, n * W);
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
template <typename U>
void sums(std::byte* v, std::size_t n) {
  U prev = 0;
  for (std::size_t i = 0; i < n; ++i) {
    prev = static_cast<U>(prev + load<U>(v + i * sizeof(U)));
    std::memcpy(v + i * sizeof(U), &prev, sizeof prev);
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

// `only`: undoing (forward false), the channels to restore; the others are
// left preconditioned (a reader that projects never reads them).
void precondition(std::span<std::byte> body, std::size_t n, bool forward, std::vector<std::byte>& scratch,
                  ChannelSet only = kAllChannels) {
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
    const auto diff = [&](bool sum) {
      if (!differenced) return;
      if (g.width == 4) sum ? sums<std::uint32_t>(g.values, n) : differences<std::uint32_t>(g.values, n);
      else sum ? sums<std::uint64_t>(g.values, n) : differences<std::uint64_t>(g.values, n);
    };
    const auto planes = [&](bool to_planes) {
      if (g.width == 4) bit_planes<4>(g.values, n, to_planes, scratch);
      else bit_planes<8>(g.values, n, to_planes, scratch);
    };
    if (forward) {
      diff(false);
      planes(true);
    } else {
      planes(false);
      diff(true);
    }
  }
  if (!forward && residual_dt && (only & (ChannelSet{1} << kPeriod)) != 0)
    period_residuals(seg[kPeriod].values, seg[kTime].values, n);
}

// zstd contexts, one per thread that encodes or decodes (the writer thread,
// analysis workers), kept for the thread's life: creating one costs more
// than compressing a chunk.
struct ZstdContexts {
  ZSTD_CCtx* c = nullptr;
  ZSTD_DCtx* d = nullptr;
  ~ZstdContexts() {
    ZSTD_freeCCtx(c);
    ZSTD_freeDCtx(d);
  }
};
thread_local ZstdContexts tls_zstd;
thread_local std::vector<std::byte> tls_shuffle;  // the encoder's precondition scratch

// zstd level 1: the fastest standard level; higher levels gained under 1 %
// in size on the demo study's chunks (BENCHMARKS.md, issue 20 goal 2).
constexpr int kZstdLevel = 1;

// The worst-case format-1 body of n updates: 28 tags, every channel per
// update (t_s's running sum is smaller).
constexpr std::size_t kBytesPerUpdate = 8 + 8 + 4 * (kEndFloat - kFirstFloat) + 4 + 4 + 1;
constexpr std::size_t max_body_bytes(std::size_t n) noexcept { return kChunkChannels + n * kBytesPerUpdate; }

ChunkError structure(const std::string& what) { return ChunkError(ChunkError::Kind::kStructure, what); }

// A plain body (preconditioned) as one zstd frame -- level 1, its content
// size and content checksum in it -- behind room for the 5-byte header.
std::vector<std::byte> compress_body(std::span<const std::byte> plain) {
  if (tls_zstd.c == nullptr) {
    if ((tls_zstd.c = ZSTD_createCCtx()) == nullptr) throw std::bad_alloc();
    for (const auto& [parameter, value] :
         {std::pair{ZSTD_c_compressionLevel, kZstdLevel}, std::pair{ZSTD_c_checksumFlag, 1},
          std::pair{ZSTD_c_contentSizeFlag, 1}}) {
      const std::size_t rc = ZSTD_CCtx_setParameter(tls_zstd.c, parameter, value);
      if (ZSTD_isError(rc))
        throw std::runtime_error(std::string("zstd refused a compression parameter: ") + ZSTD_getErrorName(rc));
    }
  }
  std::vector<std::byte> packed(kChunkHeaderBytes + ZSTD_compressBound(plain.size()));
  const std::size_t size = ZSTD_compress2(tls_zstd.c, packed.data() + kChunkHeaderBytes,
                                          packed.size() - kChunkHeaderBytes, plain.data(), plain.size());
  if (ZSTD_isError(size))
    throw std::runtime_error(std::string("zstd could not compress a sample chunk: ") + ZSTD_getErrorName(size));
  packed.resize(kChunkHeaderBytes + size);
  return packed;
}

// A chunk's zstd frame, checked before anything is allocated for it: one
// frame (RFC 8878 section 3.1.1: magic number, then the frame header
// descriptor) that states its content size, at most `most` bytes (what the
// row's count of updates can take), with the content checksum flag when
// `need_checksum`, and nothing after it. Returns the content size.
std::size_t check_frame(std::span<const std::byte> frame, std::size_t most, bool need_checksum) {
  constexpr std::array<std::uint8_t, 4> kMagic{0x28, 0xB5, 0x2F, 0xFD};  // 0xFD2FB528 little-endian
  bool magic = frame.size() > kMagic.size();
  for (std::size_t i = 0; magic && i < kMagic.size(); ++i) magic = std::to_integer<std::uint8_t>(frame[i]) == kMagic[i];
  if (!magic) throw structure("the zstd frame does not decompress (it does not start with a zstd frame's magic number)");
  const unsigned long long size = ZSTD_getFrameContentSize(frame.data(), frame.size());
  if (size == ZSTD_CONTENTSIZE_ERROR) throw structure("the zstd frame does not decompress (no valid frame header)");
  if (size == ZSTD_CONTENTSIZE_UNKNOWN) throw structure("the zstd frame does not state its content size");
  if (size > most)
    throw structure("the zstd frame's header states " + std::to_string(size) + " bytes, more than the " +
                    std::to_string(most) + " that the row's count of updates can take");
  // Frame_Header_Descriptor bit 2: Content_Checksum_flag.
  if (need_checksum && (std::to_integer<std::uint8_t>(frame[4]) & 0x04) == 0)
    throw structure("the zstd frame carries no content checksum (format 3 frames must)");
  const std::size_t compressed = ZSTD_findFrameCompressedSize(frame.data(), frame.size());
  if (ZSTD_isError(compressed))
    throw structure(std::string("the zstd frame does not decompress: ") + ZSTD_getErrorName(compressed));
  if (compressed != frame.size())
    throw structure(std::to_string(frame.size() - compressed) +
                    " bytes follow the zstd frame (a chunk holds exactly one frame)");
  return static_cast<std::size_t>(size);
}

// The checked frame decompressed into `out` (its content checksum, when it
// has one, verified by zstd).
void decompress(std::span<const std::byte> frame, std::size_t size, std::vector<std::byte>& out) {
  if (tls_zstd.d == nullptr && (tls_zstd.d = ZSTD_createDCtx()) == nullptr) throw std::bad_alloc();
  out.resize(size);
  const std::size_t got = ZSTD_decompressDCtx(tls_zstd.d, out.data(), out.size(), frame.data(), frame.size());
  if (ZSTD_isError(got) || got != size)
    throw structure(std::string("the zstd frame does not decompress: ") +
                    (ZSTD_isError(got) ? ZSTD_getErrorName(got) : "shorter than its header says"));
}

void check_count(std::uint64_t count) {
  if (count == 0 || count > kMaxChunkUpdates)
    throw structure("count is " + std::to_string(count) + ", must be 1.." + std::to_string(kMaxChunkUpdates));
}

void check_header_size(std::span<const std::byte> blob) {
  if (blob.size() < kChunkHeaderBytes)
    throw structure(std::to_string(blob.size()) + "-byte blob, shorter than the " +
                    std::to_string(kChunkHeaderBytes) + "-byte header");
}

[[noreturn]] void checksum_mismatch(std::uint32_t want, std::uint32_t got, const char* scheme = "") {
  throw ChunkError(ChunkError::Kind::kChecksum, std::string("checksum mismatch (stored CRC-32C ") + scheme +
                                                    hex32(want) + ", the data gives " + hex32(got) +
                                                    "): the chunk is damaged");
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

// Format 0's body: the old blob whole, its own format byte (1) first.
std::span<const std::byte> legacy_body(std::span<const std::byte> payload) {
  const int legacy = payload.empty() ? -1 : std::to_integer<int>(payload[0]);
  if (legacy != 1) throw structure("migrated chunk starts with format " + std::to_string(legacy) + ", expected 1");
  return payload.subspan(1);
}

template <typename U>
U le(const std::byte* p) noexcept {
  return load<U>(p);
}

// One channel's values for updates begin .. begin + n - 1: a constant
// (`tag` 1) fills the window, a per-update channel is read at its place.
template <typename U, typename Set>
void fill(std::uint8_t tag, const std::byte* values, std::size_t begin, std::size_t n, Set set) {
  if (tag == kConstant) {
    const U v = le<U>(values);
    for (std::size_t i = 0; i < n; ++i) set(i, v);
  } else {
    const std::byte* p = values + begin * sizeof(U);
    for (std::size_t i = 0; i < n; ++i) set(i, le<U>(p + i * sizeof(U)));
  }
}

}  // namespace

const char* to_string(ChunkError::Kind kind) noexcept {
  switch (kind) {
    case ChunkError::Kind::kChecksum: return "checksum";
    case ChunkError::Kind::kUnknownFormat: return "format";
    case ChunkError::Kind::kStructure: return "structure";
    case ChunkError::Kind::kPlacement: return "placement";
  }
  return "structure";
}

std::vector<std::byte> encode_chunk(std::int64_t trial_id, int instrument, std::span<const StoredSample> s,
                                    std::uint8_t format) {
  if (format != kChunkFormat && format != kChunkFormatPlain)
    throw std::invalid_argument("encode_chunk(): format " + std::to_string(format) + ", must be " +
                                std::to_string(kChunkFormatPlain) + " or " + std::to_string(kChunkFormat));
  if (s.empty() || s.size() > kMaxChunkUpdates)
    throw std::invalid_argument("encode_chunk(): " + std::to_string(s.size()) + " samples, must be 1.." +
                                std::to_string(kMaxChunkUpdates));
  for (std::size_t i = 1; i < s.size(); ++i)
    if (s[i].tick != s[0].tick + i)
      throw std::invalid_argument("encode_chunk(): ticks must be consecutive; tick " + std::to_string(s[i].tick) +
                                  " follows " + std::to_string(s[i - 1].tick));
  const std::size_t n = s.size();
  Writer w(kChunkHeaderBytes + max_body_bytes(n));
  w.byte(kChunkFormatPlain);
  w.le<4>(0);  // the checksum, filled in below
  std::vector<std::uint64_t> bits64(n);
  std::vector<std::uint32_t> bits32(n);

  for (std::size_t i = 0; i < n; ++i) bits64[i] = std::bit_cast<std::uint64_t>(s[i].dt_s);
  put_bits<8>(w, bits64.data(), n);

  // t_s: when every t is the previous t plus this dt, bit for bit (the
  // usual case with the virtual clock), t[0] alone restores the rest.
  bool running_sum = n > 1;
  for (std::size_t i = 1; i < n && running_sum; ++i)
    running_sum = std::bit_cast<std::uint64_t>(s[i - 1].t_s + s[i].dt_s) == std::bit_cast<std::uint64_t>(s[i].t_s);
  if (running_sum) {
    w.byte(kRunningSum);
    w.le<8>(std::bit_cast<std::uint64_t>(s[0].t_s));
  } else {
    for (std::size_t i = 0; i < n; ++i) bits64[i] = std::bit_cast<std::uint64_t>(s[i].t_s);
    put_bits<8>(w, bits64.data(), n);
  }

  // Float channels: converted update by update into an n x 23 table, then
  // written column by column.
  std::vector<std::uint32_t> table(n * kNumFloat);
  for (std::size_t i = 0; i < n; ++i) float_bits(s[i].value, &table[i * kNumFloat]);
  for (std::size_t c = 0; c < kNumFloat; ++c) put_bits<4>(w, &table[c], n, kNumFloat);
  for (std::size_t i = 0; i < n; ++i) bits32[i] = s[i].value.engine_status;
  put_bits<4>(w, bits32.data(), n);
  for (std::size_t i = 0; i < n; ++i) bits32[i] = std::bit_cast<std::uint32_t>(s[i].device_status);
  put_bits<4>(w, bits32.data(), n);
  for (std::size_t i = 0; i < n; ++i) bits32[i] = s[i].value.in_contact ? 1u : 0u;
  put_bits<1>(w, bits32.data(), n);
  std::vector<std::byte> blob = w.take();
  if (format == kChunkFormat) {
    // The plain body, preconditioned, becomes one zstd frame behind the
    // same 5-byte header.
    const std::span<std::byte> body = std::span(blob).subspan(kChunkHeaderBytes);
    precondition(body, n, true, tls_shuffle);
    std::vector<std::byte> packed = compress_body(body);
    packed[0] = std::byte{kChunkFormat};
    blob = std::move(packed);
  }
  const ChunkPlace place{trial_id, instrument, s[0].tick, n};
  put_crc(blob, chunk_crc(place, blob[0], std::span(blob).subspan(kChunkHeaderBytes)));
  return blob;
}

std::uint8_t verify_chunk(const ChunkPlace& place, std::span<const std::byte> blob) {
  check_header_size(blob);
  const std::uint32_t want = stored_crc(blob);
  const std::uint32_t got = chunk_crc(place, blob[0], blob.subspan(kChunkHeaderBytes));
  if (got != want) checksum_mismatch(want, got);
  const auto format = std::to_integer<std::uint8_t>(blob[0]);
  if (format == kChunkFormatSchema6)
    throw structure("chunk format 2 (a zstd frame without its content checksum) belongs to schemas 4..6, and the "
                    "migration to schema 7 converts every such chunk to format 3; this one was not converted");
  if (format != kChunkFormat && format != kChunkFormatPlain && format != kChunkFormatMigrated)
    throw ChunkError(ChunkError::Kind::kUnknownFormat,
                     "chunk format " + std::to_string(format) + " is not one this HapticLab reads (" +
                         std::to_string(kChunkFormatMigrated) + ", " + std::to_string(kChunkFormatPlain) + ", " +
                         std::to_string(kChunkFormat) + "); it was written by a newer HapticLab");
  check_count(place.count);
  return format;
}

void ChunkDecoder::unpack(const ChunkPlace& place, std::span<const std::byte> blob, bool readable,
                          ChannelSet channels) {
  count_ = 0;
  const std::uint8_t format = verify_chunk(place, blob);
  const std::span<const std::byte> payload = blob.subspan(kChunkHeaderBytes);
  const auto n = static_cast<std::size_t>(place.count);
  if (format == kChunkFormat) {
    decompress(payload, check_frame(payload, max_body_bytes(n), true), body_);
  } else {
    const std::span<const std::byte> body = format == kChunkFormatMigrated ? legacy_body(payload) : payload;
    body_.assign(body.begin(), body.end());
  }
  const std::array<Segment, kChunkChannels> seg = exact_segments(body_, n);
  if (!readable) return;
  // What the asked-for channels need: t_s as a running sum is summed from
  // dt_s; a residual dt_s (t_s per update too) is restored from t_s.
  const ChannelSet t_bit = ChannelSet{1} << kChannelT, dt_bit = ChannelSet{1} << kChannelDt;
  channels &= kAllChannels;
  if ((channels & t_bit) != 0 && seg[kChannelT].tag == kRunningSum) channels |= dt_bit;
  if ((channels & dt_bit) != 0 && seg[kChannelT].tag == kPerUpdate) channels |= t_bit;
  if (format == kChunkFormat) precondition(body_, n, false, scratch_, channels);
  channels_read_ = channels;
  for (std::size_t c = 0; c < kChunkChannels; ++c)
    channels_[c] = {seg[c].tag, static_cast<std::size_t>(seg[c].values - body_.data())};
  first_tick_ = place.first_tick;
  format_ = format;
  t_next_ = 0;
  count_ = n;
}

void ChunkDecoder::load(const ChunkPlace& place, std::span<const std::byte> blob, ChannelSet channels) {
  unpack(place, blob, true, channels);
}

void ChunkDecoder::check(const ChunkPlace& place, std::span<const std::byte> blob) {
  unpack(place, blob, false, kAllChannels);
}

void ChunkDecoder::read(std::size_t begin, std::size_t end, StoredSample* s) noexcept {
  const std::size_t n = end - begin;
  const std::byte* body = body_.data();
  const auto at = [&](std::size_t c) { return body + channels_[c].offset; };
  const auto tag = [&](std::size_t c) { return channels_[c].tag; };
  const auto wanted = [&](std::size_t c) { return (channels_read_ & (ChannelSet{1} << c)) != 0; };
  for (std::size_t i = 0; i < n; ++i) s[i].tick = first_tick_ + begin + i;
  if (wanted(0))
    fill<std::uint64_t>(tag(0), at(0), begin, n, [&](std::size_t i, std::uint64_t v) { s[i].dt_s = std::bit_cast<double>(v); });
  if (!wanted(1)) {
    // t_s not asked for
  } else if (tag(1) == kRunningSum) {
    // t[i] = t[i-1] + dt[i] from t[0]: carried over from the previous
    // window when this one follows it, else summed again from the start.
    const auto dt = [&](std::size_t k) {
      return std::bit_cast<double>(le<std::uint64_t>(at(0) + (tag(0) == kConstant ? 0 : k * 8)));
    };
    if (t_next_ == 0 || begin < t_next_) {
      t_prev_ = std::bit_cast<double>(le<std::uint64_t>(at(1)));
      t_next_ = 1;
    }
    for (; t_next_ < begin; ++t_next_) t_prev_ += dt(t_next_);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = begin + i;
      if (k > 0) t_prev_ += s[i].dt_s;
      s[i].t_s = t_prev_;
      t_next_ = k + 1;
    }
  } else {
    fill<std::uint64_t>(tag(1), at(1), begin, n, [&](std::size_t i, std::uint64_t v) { s[i].t_s = std::bit_cast<double>(v); });
  }
  for (std::size_t c = kFirstFloat; c < kEndFloat; ++c) {
    if (!wanted(c)) continue;
    fill<std::uint32_t>(tag(c), at(c), begin, n, [&](std::size_t i, std::uint32_t v) {
      *float_channel(s[i].value, c) = double{std::bit_cast<float>(v)};
    });
  }
  if (wanted(kEngineStatus))
    fill<std::uint32_t>(tag(kEngineStatus), at(kEngineStatus), begin, n,
                        [&](std::size_t i, std::uint32_t v) { s[i].value.engine_status = v; });
  if (wanted(kDeviceStatus))
    fill<std::uint32_t>(tag(kDeviceStatus), at(kDeviceStatus), begin, n,
                        [&](std::size_t i, std::uint32_t v) { s[i].device_status = std::bit_cast<std::int32_t>(v); });
  if (wanted(kInContact))
    fill<std::uint8_t>(tag(kInContact), at(kInContact), begin, n,
                       [&](std::size_t i, std::uint8_t v) { s[i].value.in_contact = v != 0; });
}

void decode_chunk(const ChunkPlace& place, std::span<const std::byte> blob, std::vector<StoredSample>& out) {
  thread_local ChunkDecoder decoder;
  decoder.load(place, blob);
  const std::size_t base = out.size();
  out.resize(base + decoder.size());
  decoder.read(0, decoder.size(), out.data() + base);
}

std::vector<std::byte> checksum_legacy_chunk(std::uint64_t first_tick, std::size_t count,
                                             std::span<const std::byte> legacy_blob) {
  std::vector<std::byte> blob(kChunkHeaderBytes + legacy_blob.size());
  blob[0] = std::byte{kChunkFormatMigrated};
  std::copy(legacy_blob.begin(), legacy_blob.end(), blob.begin() + kChunkHeaderBytes);
  put_crc(blob, schema6_crc(first_tick, count, blob[0], legacy_blob));
  return blob;
}

std::vector<std::byte> move_chunk(const ChunkPlace& from, const ChunkPlace& to, std::span<const std::byte> blob) {
  if (from.first_tick != to.first_tick || from.count != to.count)
    throw std::invalid_argument("move_chunk: ticks " + std::to_string(from.first_tick) + "+" +
                                std::to_string(from.count) + " cannot become " + std::to_string(to.first_tick) +
                                "+" + std::to_string(to.count) + ": only the trial and instrument may change");
  ChunkDecoder().check(from, blob);
  std::vector<std::byte> out(blob.begin(), blob.end());
  put_crc(out, chunk_crc(to, out[0], std::span(out).subspan(kChunkHeaderBytes)));
  return out;
}

std::vector<std::byte> upgrade_schema6_chunk(const ChunkPlace& place, std::span<const std::byte> blob) {
  check_header_size(blob);
  const std::span<const std::byte> payload = blob.subspan(kChunkHeaderBytes);
  const std::uint32_t want = stored_crc(blob);
  const std::uint32_t got = schema6_crc(place.first_tick, place.count, blob[0], payload);
  if (got != want) checksum_mismatch(want, got, "of schema 6 ");
  const auto format = std::to_integer<std::uint8_t>(blob[0]);
  if (format != kChunkFormatSchema6 && format != kChunkFormatPlain && format != kChunkFormatMigrated)
    throw ChunkError(ChunkError::Kind::kUnknownFormat,
                     "chunk format " + std::to_string(format) + " is not one schema 6 had (0, 1, 2)");
  check_count(place.count);
  const auto n = static_cast<std::size_t>(place.count);
  // Decoded in full, as schema 6 read it, before it gets a checksum that
  // vouches for it: format 2's frame decompresses to a body of exactly n
  // updates (still preconditioned: format 3 holds the same body).
  std::vector<std::byte> plain;
  if (format == kChunkFormatSchema6) {
    decompress(payload, check_frame(payload, max_body_bytes(n), false), plain);
  } else {
    const std::span<const std::byte> body = format == kChunkFormatMigrated ? legacy_body(payload) : payload;
    plain.assign(body.begin(), body.end());
  }
  exact_segments(plain, n);
  std::vector<std::byte> out;
  if (format == kChunkFormatSchema6) {
    out = compress_body(plain);
    out[0] = std::byte{kChunkFormat};
  } else {
    out.assign(blob.begin(), blob.end());
  }
  put_crc(out, chunk_crc(place, out[0], std::span(out).subspan(kChunkHeaderBytes)));
  return out;
}

}  // namespace hapticlab::db
