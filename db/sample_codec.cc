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

namespace hapticlab::db {

// One list for every sample table (core/loop/sample_channels.h).
const std::array<const char*, kChunkChannels> kChannelNames = kSampleChannelNames;

namespace {

// The checksum of a chunk: its row's first tick and count, then the blob
// without the checksum bytes (format byte, body).
std::uint32_t chunk_crc(std::uint64_t first_tick, std::uint64_t count, std::byte format,
                        std::span<const std::byte> body) noexcept {
  std::array<std::byte, 17> head{};
  for (int i = 0; i < 8; ++i) {
    head[static_cast<std::size_t>(i)] = static_cast<std::byte>(first_tick >> (8 * i));
    head[static_cast<std::size_t>(8 + i)] = static_cast<std::byte>(count >> (8 * i));
  }
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

class Reader {
 public:
  explicit Reader(std::span<const std::byte> blob) : blob_(blob) {}
  // The next `Bytes` bytes, little-endian (asserted above for the memcpy).
  template <int Bytes>
  std::uint64_t get() {
    if (pos_ + Bytes > blob_.size()) throw ChunkError(ChunkError::Kind::kStructure, "blob too short for its count");
    std::uint64_t v = 0;
    std::memcpy(&v, blob_.data() + pos_, Bytes);
    pos_ += Bytes;
    return v;
  }
  bool at_end() const noexcept { return pos_ == blob_.size(); }

 private:
  std::span<const std::byte> blob_;
  std::size_t pos_ = 0;
};

// Reads the values of one channel whose tag was just read, calling
// `set(i, bits)` for every sample.
template <int Bytes, typename Set>
void get_values(Reader& r, std::uint8_t tag, std::size_t n, std::size_t channel, Set set) {
  if (tag == kConstant) {
    const std::uint64_t v = r.get<Bytes>();
    for (std::size_t i = 0; i < n; ++i) set(i, v);
  } else if (tag == kPerUpdate) {
    for (std::size_t i = 0; i < n; ++i) set(i, r.get<Bytes>());
  } else {
    throw ChunkError(ChunkError::Kind::kStructure,
                     std::string("channel ") + kChannelNames[channel] + " has unknown tag " + std::to_string(tag));
  }
}

template <int Bytes, typename Set>
void get_channel(Reader& r, std::size_t n, std::size_t channel, Set set) {
  get_values<Bytes>(r, static_cast<std::uint8_t>(r.get<1>()), n, channel, set);
}

void decode_into(Reader& r, std::size_t count, StoredSample* s) {
  get_channel<8>(r, count, 0, [&](std::size_t i, std::uint64_t v) { s[i].dt_s = std::bit_cast<double>(v); });
  const auto t_tag = static_cast<std::uint8_t>(r.get<1>());
  if (t_tag == kRunningSum) {
    s[0].t_s = std::bit_cast<double>(r.get<8>());
    for (std::size_t i = 1; i < count; ++i) s[i].t_s = s[i - 1].t_s + s[i].dt_s;
  } else {
    get_values<8>(r, t_tag, count, 1, [&](std::size_t i, std::uint64_t v) { s[i].t_s = std::bit_cast<double>(v); });
  }
  for (std::size_t c = kFirstFloat; c < kEndFloat; ++c)
    get_channel<4>(r, count, c, [&](std::size_t i, std::uint64_t v) {
      *float_channel(s[i].value, c) = double{std::bit_cast<float>(static_cast<std::uint32_t>(v))};
    });
  get_channel<4>(r, count, kEngineStatus,
                 [&](std::size_t i, std::uint64_t v) { s[i].value.engine_status = static_cast<std::uint32_t>(v); });
  get_channel<4>(r, count, kDeviceStatus, [&](std::size_t i, std::uint64_t v) {
    s[i].device_status = std::bit_cast<std::int32_t>(static_cast<std::uint32_t>(v));
  });
  get_channel<1>(r, count, kInContact, [&](std::size_t i, std::uint64_t v) { s[i].value.in_contact = v != 0; });
}

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

std::array<Segment, kChunkChannels> segments(std::span<std::byte> body, std::size_t n) {
  std::array<Segment, kChunkChannels> out;
  std::size_t pos = 0;
  const auto need = [&](std::size_t bytes) {
    if (pos + bytes > body.size()) throw ChunkError(ChunkError::Kind::kStructure, "blob too short for its count");
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

void precondition(std::span<std::byte> body, std::size_t n, bool forward, std::vector<std::byte>& scratch) {
  const std::array<Segment, kChunkChannels> seg = segments(body, n);
  constexpr std::size_t kPeriod = 0, kTime = 1;
  // dt as residuals of t's differences: t must be as stored when they are
  // made, and restored before they are undone.
  const bool residual_dt = seg[kPeriod].tag == kPerUpdate && seg[kTime].tag == kPerUpdate;
  if (forward && residual_dt) period_residuals(seg[kPeriod].values, seg[kTime].values, n);
  for (std::size_t c = 0; c < kChunkChannels; ++c) {
    const Segment& g = seg[c];
    if (g.tag != kPerUpdate || g.width == 1) continue;
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
  if (!forward && residual_dt) period_residuals(seg[kPeriod].values, seg[kTime].values, n);
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
thread_local std::vector<std::byte> tls_plain;    // a decompressed body
thread_local std::vector<std::byte> tls_shuffle;  // precondition's scratch

// zstd level 1: the fastest standard level; higher levels gained under 1 %
// in size on the demo study's chunks (BENCHMARKS.md, issue 20 goal 2).
constexpr int kZstdLevel = 1;

// The worst-case format-1 body of n updates: 28 tags, every channel per
// update (t_s's running sum is smaller).
constexpr std::size_t kBytesPerUpdate = 8 + 8 + 4 * (kEndFloat - kFirstFloat) + 4 + 4 + 1;
constexpr std::size_t max_body_bytes(std::size_t n) noexcept { return kChunkChannels + n * kBytesPerUpdate; }

}  // namespace

std::vector<std::byte> encode_chunk(std::span<const StoredSample> s, std::uint8_t format) {
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
    if (tls_zstd.c == nullptr && (tls_zstd.c = ZSTD_createCCtx()) == nullptr) throw std::bad_alloc();
    std::vector<std::byte> packed(kChunkHeaderBytes + ZSTD_compressBound(body.size()));
    const std::size_t size = ZSTD_compressCCtx(tls_zstd.c, packed.data() + kChunkHeaderBytes,
                                               packed.size() - kChunkHeaderBytes, body.data(), body.size(), kZstdLevel);
    if (ZSTD_isError(size))
      throw std::runtime_error(std::string("zstd could not compress a sample chunk: ") + ZSTD_getErrorName(size));
    packed.resize(kChunkHeaderBytes + size);
    packed[0] = std::byte{kChunkFormat};
    blob = std::move(packed);
  }
  put_crc(blob, chunk_crc(s[0].tick, n, blob[0], std::span(blob).subspan(kChunkHeaderBytes)));
  return blob;
}

std::uint8_t verify_chunk(std::uint64_t first_tick, std::size_t count, std::span<const std::byte> blob) {
  if (blob.size() < kChunkHeaderBytes)
    throw ChunkError(ChunkError::Kind::kStructure, std::to_string(blob.size()) + "-byte blob, shorter than the " +
                                                       std::to_string(kChunkHeaderBytes) + "-byte header");
  const std::uint32_t want = stored_crc(blob);
  const std::uint32_t got = chunk_crc(first_tick, count, blob[0], blob.subspan(kChunkHeaderBytes));
  if (got != want)
    throw ChunkError(ChunkError::Kind::kChecksum, "checksum mismatch (stored CRC-32C " + hex32(want) +
                                                      ", the data gives " + hex32(got) + "): the chunk is damaged");
  const auto format = std::to_integer<std::uint8_t>(blob[0]);
  if (format != kChunkFormat && format != kChunkFormatPlain && format != kChunkFormatMigrated)
    throw ChunkError(ChunkError::Kind::kUnknownFormat,
                     "chunk format " + std::to_string(format) + " is not one this HapticLab reads (" +
                         std::to_string(kChunkFormatMigrated) + ", " + std::to_string(kChunkFormatPlain) + ", " +
                         std::to_string(kChunkFormat) + "); it was written by a newer HapticLab");
  return format;
}

std::vector<std::byte> checksum_legacy_chunk(std::uint64_t first_tick, std::size_t count,
                                             std::span<const std::byte> legacy_blob) {
  std::vector<std::byte> blob(kChunkHeaderBytes + legacy_blob.size());
  blob[0] = std::byte{kChunkFormatMigrated};
  std::copy(legacy_blob.begin(), legacy_blob.end(), blob.begin() + kChunkHeaderBytes);
  put_crc(blob, chunk_crc(first_tick, count, blob[0], legacy_blob));
  return blob;
}

void decode_chunk(std::uint64_t first_tick, std::size_t count, std::span<const std::byte> blob,
                  std::vector<StoredSample>& out) {
  const std::uint8_t format = verify_chunk(first_tick, count, blob);
  if (count == 0 || count > kMaxChunkUpdates)
    throw ChunkError(ChunkError::Kind::kStructure,
                     "count is " + std::to_string(count) + ", must be 1.." + std::to_string(kMaxChunkUpdates));
  std::span<const std::byte> body = blob.subspan(kChunkHeaderBytes);
  if (format == kChunkFormat) {
    // A frame that does not decompress, or not to a body of this count,
    // passed its checksum: it was written wrong, not damaged later. Either
    // way the chunk is unusable and reported like damage.
    const unsigned long long plain = ZSTD_getFrameContentSize(body.data(), body.size());
    if (plain == ZSTD_CONTENTSIZE_ERROR || plain == ZSTD_CONTENTSIZE_UNKNOWN || plain > max_body_bytes(count))
      throw ChunkError(ChunkError::Kind::kStructure,
                       "the zstd frame does not decompress (no valid frame header for " + std::to_string(count) +
                           " updates)");
    if (tls_zstd.d == nullptr && (tls_zstd.d = ZSTD_createDCtx()) == nullptr) throw std::bad_alloc();
    tls_plain.resize(static_cast<std::size_t>(plain));
    const std::size_t got = ZSTD_decompressDCtx(tls_zstd.d, tls_plain.data(), tls_plain.size(), body.data(), body.size());
    if (ZSTD_isError(got) || got != plain)
      throw ChunkError(ChunkError::Kind::kStructure,
                       std::string("the zstd frame does not decompress: ") +
                           (ZSTD_isError(got) ? ZSTD_getErrorName(got) : "shorter than its header says"));
    precondition(tls_plain, count, false, tls_shuffle);
    body = tls_plain;
  }
  Reader r(body);
  // Format 0 holds the old blob whole, its own format byte (1) first.
  if (format == kChunkFormatMigrated) {
    const auto legacy = r.get<1>();
    if (legacy != 1)
      throw ChunkError(ChunkError::Kind::kStructure,
                       "migrated chunk starts with format " + std::to_string(legacy) + ", expected 1");
  }
  const std::size_t base = out.size();
  out.resize(base + count);
  StoredSample* s = out.data() + base;
  for (std::size_t i = 0; i < count; ++i) s[i].tick = first_tick + i;

  try {
    decode_into(r, count, s);
  } catch (...) {
    out.resize(base);
    throw;
  }
  if (!r.at_end()) {
    out.resize(base);
    throw ChunkError(ChunkError::Kind::kStructure, std::to_string(body.size()) + " bytes, more than " +
                                                       std::to_string(count) + " samples use");
  }
}

}  // namespace hapticlab::db
