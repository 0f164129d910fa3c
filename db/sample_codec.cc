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

#include "db/chunk_body.h"

namespace hapticlab::db {

// One list for every sample table (core/loop/sample_channels.h).
const std::array<const char*, kChunkChannels> kChannelNames = kSampleChannelNames;

namespace {

// The body's layout and format 3's transforms (chunk_body.h).
using chunk::check_frame;
using chunk::compress_body;
using chunk::decompress;
using chunk::exact_segments;
using chunk::kConstant;
using chunk::kDeviceStatus;
using chunk::kEndFloat;
using chunk::kEngineStatus;
using chunk::kFirstFloat;
using chunk::kInContact;
using chunk::kPerUpdate;
using chunk::kRunningSum;
using chunk::load;
using chunk::max_body_bytes;
using chunk::precondition;
using chunk::Segment;
using chunk::structure;

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

thread_local std::vector<std::byte> tls_shuffle;  // the encoder's precondition scratch

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
  if (wanted(1)) times(begin, n, [&](std::size_t i, double t) { s[i].t_s = t; });
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

template <typename Set>
void ChunkDecoder::times(std::size_t begin, std::size_t n, Set set) noexcept {
  const std::byte* const dt_at = body_.data() + channels_[kChannelDt].offset;
  const std::byte* const t_at = body_.data() + channels_[kChannelT].offset;
  if (channels_[kChannelT].tag != kRunningSum) {
    fill<std::uint64_t>(channels_[kChannelT].tag, t_at, begin, n,
                        [&](std::size_t i, std::uint64_t v) { set(i, std::bit_cast<double>(v)); });
    return;
  }
  // t[i] = t[i-1] + dt[i] from t[0]: carried over from the previous window
  // when this one follows it, else summed again from the start.
  const std::size_t dt_stride = channels_[kChannelDt].tag == kConstant ? 0 : 8;
  const auto dt = [&](std::size_t k) { return std::bit_cast<double>(le<std::uint64_t>(dt_at + k * dt_stride)); };
  if (t_next_ == 0 || begin < t_next_) {
    t_prev_ = std::bit_cast<double>(le<std::uint64_t>(t_at));
    t_next_ = 1;
  }
  for (; t_next_ < begin; ++t_next_) t_prev_ += dt(t_next_);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t k = begin + i;
    if (k > 0) t_prev_ += dt(k);
    set(i, t_prev_);
    t_next_ = k + 1;
  }
}

void ChunkDecoder::read_t(std::size_t begin, std::size_t end, double* out) noexcept {
  times(begin, end - begin, [&](std::size_t i, double t) { out[i] = t; });
}

FloatColumn ChunkDecoder::column(std::size_t c, std::size_t begin) const noexcept {
  const Channel& ch = channels_[c];
  const std::size_t stride = ch.tag == kConstant ? 0 : 4;
  return {body_.data() + ch.offset + begin * stride, stride};
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
