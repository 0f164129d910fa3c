#pragma once
// Sample chunks: up to a few thousand consecutive updates of one instrument
// packed into one BLOB (one row of sample_chunk), about 8x smaller and far
// faster to write than a row per sample.
//
// Layout (format 1), all numbers little-endian:
//
//   byte 0          format = 1
//   then 28 channels, in the order of kChannelNames, each:
//     1 byte tag    0 = `count` values follow, one per update, in order
//                   1 = one value follows, the same for every update
//                   2 = (t_s only) one float64 t[0] follows; the rest are
//                       t[i] = t[i-1] + dt[i] in float64, which the encoder
//                       checked is bit-exact before choosing this tag
//     values        float64 (t_s, dt_s), uint32 (engine_status), int32
//                   (device_status), uint8 0/1 (in_contact), float32 (the
//                   23 other channels)
//
// Column-major (channel after channel) so equal channels collapse to one
// value (forces out of contact, unused joints, status words) and the rest
// would compress well should a compressor ever be added.
//
// Precision: t_s and dt_s are exact (float64). The physical channels are
// rounded to the nearest float32, a relative error of at most 2^-24 (6e-8):
// 6 nm on a 0.1 m position, 0.6 µN on a 10 N force, 0.2 µrad on 3 rad. A
// value beyond float32's range is stored as ±infinity; NaN stays NaN. The
// integer channels are exact.
//
// The chunk's first tick and count are columns of the row, not part of the
// blob; the ticks of a chunk are consecutive (first_tick + i).

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "core/loop/loop_sample.h"

namespace hapticlab::db {

// One update of one instrument as stored and read back.
struct StoredSample {
  std::uint64_t tick = 0;
  double t_s = 0.0;   // loop clock at the start of the update [s]
  double dt_s = 0.0;  // measured period [s]
  std::int32_t device_status = 0;
  InstrumentSample value;  // units as in core/loop/loop_sample.h
};

inline constexpr std::uint8_t kChunkFormat = 1;
inline constexpr std::size_t kChunkChannels = 28;
// Most updates one chunk may hold (a damaged count never allocates more).
inline constexpr std::size_t kMaxChunkUpdates = std::size_t{1} << 20;
// Channel names in blob order; also the CSV column names (export_csv.h).
extern const std::array<const char*, kChunkChannels> kChannelNames;

// `samples`: 1..kMaxChunkUpdates, ticks consecutive; throws std::invalid_argument
// otherwise. Appends nothing: returns a fresh blob.
std::vector<std::byte> encode_chunk(std::span<const StoredSample> samples);

// Decodes a blob of `count` samples starting at `first_tick` and appends
// them to `out`. Throws std::runtime_error if the blob is not format 1 or
// its size does not match `count` (a damaged row is refused, never guessed).
void decode_chunk(std::uint64_t first_tick, std::size_t count, std::span<const std::byte> blob,
                  std::vector<StoredSample>& out);

// The value stored for a float32 channel: nearest float, ±inf beyond range.
float to_stored_float(double value) noexcept;

}  // namespace hapticlab::db
