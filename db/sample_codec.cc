#include "db/sample_codec.h"

#include "core/loop/sample_channels.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

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

class Reader {
 public:
  explicit Reader(std::span<const std::byte> blob) : blob_(blob) {}
  std::uint64_t get(int bytes) {
    if (pos_ + static_cast<std::size_t>(bytes) > blob_.size())
      throw ChunkError(ChunkError::Kind::kStructure, "blob too short for its count");
    std::uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= std::uint64_t(std::to_integer<std::uint8_t>(blob_[pos_++])) << (8 * i);
    return v;
  }
  bool at_end() const noexcept { return pos_ == blob_.size(); }

 private:
  std::span<const std::byte> blob_;
  std::size_t pos_ = 0;
};

// Reads the values of one channel whose tag was just read, calling
// `set(i, bits)` for every sample.
template <typename Set>
void get_values(Reader& r, std::uint8_t tag, std::size_t n, int bytes, std::size_t channel, Set set) {
  if (tag == kConstant) {
    const std::uint64_t v = r.get(bytes);
    for (std::size_t i = 0; i < n; ++i) set(i, v);
  } else if (tag == kPerUpdate) {
    for (std::size_t i = 0; i < n; ++i) set(i, r.get(bytes));
  } else {
    throw ChunkError(ChunkError::Kind::kStructure,
                     std::string("channel ") + kChannelNames[channel] + " has unknown tag " + std::to_string(tag));
  }
}

template <typename Set>
void get_channel(Reader& r, std::size_t n, int bytes, std::size_t channel, Set set) {
  get_values(r, static_cast<std::uint8_t>(r.get(1)), n, bytes, channel, set);
}

void decode_into(Reader& r, std::size_t count, StoredSample* s) {
  get_channel(r, count, 8, 0, [&](std::size_t i, std::uint64_t v) { s[i].dt_s = std::bit_cast<double>(v); });
  const auto t_tag = static_cast<std::uint8_t>(r.get(1));
  if (t_tag == kRunningSum) {
    s[0].t_s = std::bit_cast<double>(r.get(8));
    for (std::size_t i = 1; i < count; ++i) s[i].t_s = s[i - 1].t_s + s[i].dt_s;
  } else {
    get_values(r, t_tag, count, 8, 1, [&](std::size_t i, std::uint64_t v) { s[i].t_s = std::bit_cast<double>(v); });
  }
  for (std::size_t c = kFirstFloat; c < kEndFloat; ++c)
    get_channel(r, count, 4, c, [&](std::size_t i, std::uint64_t v) {
      *float_channel(s[i].value, c) = double{std::bit_cast<float>(static_cast<std::uint32_t>(v))};
    });
  get_channel(r, count, 4, kEngineStatus,
              [&](std::size_t i, std::uint64_t v) { s[i].value.engine_status = static_cast<std::uint32_t>(v); });
  get_channel(r, count, 4, kDeviceStatus, [&](std::size_t i, std::uint64_t v) {
    s[i].device_status = std::bit_cast<std::int32_t>(static_cast<std::uint32_t>(v));
  });
  get_channel(r, count, 1, kInContact, [&](std::size_t i, std::uint64_t v) { s[i].value.in_contact = v != 0; });
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
  // Little-endian, `bytes` of `bits` (the machines we run on are
  // little-endian; the loop spells it out so the format does not depend on it).
  void le(std::uint64_t bits, int bytes) noexcept {
    for (int i = 0; i < bytes; ++i) out_[pos_++] = static_cast<std::byte>(bits >> (8 * i));
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
template <typename Bits>
void put_bits(Writer& w, const Bits* bits, std::size_t n, int bytes, std::size_t stride = 1) {
  bool constant = true;
  for (std::size_t i = 1; i < n && constant; ++i) constant = bits[i * stride] == bits[0];
  w.byte(constant ? kConstant : kPerUpdate);
  const std::size_t values = constant ? 1 : n;
  for (std::size_t i = 0; i < values; ++i) w.le(static_cast<std::uint64_t>(bits[i * stride]), bytes);
}

}  // namespace

std::vector<std::byte> encode_chunk(std::span<const StoredSample> s) {
  if (s.empty() || s.size() > kMaxChunkUpdates)
    throw std::invalid_argument("encode_chunk(): " + std::to_string(s.size()) + " samples, must be 1.." +
                                std::to_string(kMaxChunkUpdates));
  for (std::size_t i = 1; i < s.size(); ++i)
    if (s[i].tick != s[0].tick + i)
      throw std::invalid_argument("encode_chunk(): ticks must be consecutive; tick " + std::to_string(s[i].tick) +
                                  " follows " + std::to_string(s[i - 1].tick));
  const std::size_t n = s.size();
  // Worst case: header, 28 tags, every channel per update, t_s's 8 bytes.
  constexpr std::size_t kBytesPerUpdate = 8 + 8 + 4 * (kEndFloat - kFirstFloat) + 4 + 4 + 1;
  Writer w(kChunkHeaderBytes + kChunkChannels + n * kBytesPerUpdate);
  w.byte(kChunkFormat);
  w.le(0, 4);  // the checksum, filled in below
  std::vector<std::uint64_t> bits64(n);
  std::vector<std::uint32_t> bits32(n);

  for (std::size_t i = 0; i < n; ++i) bits64[i] = std::bit_cast<std::uint64_t>(s[i].dt_s);
  put_bits(w, bits64.data(), n, 8);

  // t_s: when every t is the previous t plus this dt, bit for bit (the
  // usual case with the virtual clock), t[0] alone restores the rest.
  bool running_sum = n > 1;
  for (std::size_t i = 1; i < n && running_sum; ++i)
    running_sum = std::bit_cast<std::uint64_t>(s[i - 1].t_s + s[i].dt_s) == std::bit_cast<std::uint64_t>(s[i].t_s);
  if (running_sum) {
    w.byte(kRunningSum);
    w.le(std::bit_cast<std::uint64_t>(s[0].t_s), 8);
  } else {
    for (std::size_t i = 0; i < n; ++i) bits64[i] = std::bit_cast<std::uint64_t>(s[i].t_s);
    put_bits(w, bits64.data(), n, 8);
  }

  // Float channels: converted update by update into an n x 23 table, then
  // written column by column.
  std::vector<std::uint32_t> table(n * kNumFloat);
  for (std::size_t i = 0; i < n; ++i) float_bits(s[i].value, &table[i * kNumFloat]);
  for (std::size_t c = 0; c < kNumFloat; ++c) put_bits(w, &table[c], n, 4, kNumFloat);
  for (std::size_t i = 0; i < n; ++i) bits32[i] = s[i].value.engine_status;
  put_bits(w, bits32.data(), n, 4);
  for (std::size_t i = 0; i < n; ++i) bits32[i] = std::bit_cast<std::uint32_t>(s[i].device_status);
  put_bits(w, bits32.data(), n, 4);
  for (std::size_t i = 0; i < n; ++i) bits32[i] = s[i].value.in_contact ? 1u : 0u;
  put_bits(w, bits32.data(), n, 1);
  std::vector<std::byte> blob = w.take();
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
  if (format != kChunkFormat && format != kChunkFormatMigrated)
    throw ChunkError(ChunkError::Kind::kUnknownFormat,
                     "chunk format " + std::to_string(format) + " is not one this HapticLab reads (" +
                         std::to_string(kChunkFormatMigrated) + ", " + std::to_string(kChunkFormat) +
                         "); it was written by a newer HapticLab");
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
  Reader r(blob.subspan(kChunkHeaderBytes));
  // Format 0 holds the old blob whole, its own format byte (1) first.
  if (format == kChunkFormatMigrated) {
    const auto legacy = r.get(1);
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
    throw ChunkError(ChunkError::Kind::kStructure, std::to_string(blob.size()) + " bytes, more than " +
                                                       std::to_string(count) + " samples use");
  }
}

}  // namespace hapticlab::db
