#pragma once
// Sample chunks: up to a few thousand consecutive updates of one instrument
// packed into one BLOB (one row of sample_chunk), about 8x smaller and far
// faster to write than a row per sample.
//
// Layout, all numbers little-endian. A 5-byte header, the same for every
// format, so a checksum can be verified without decoding:
//
//   byte 0          format: 2 = the format-1 body, preconditioned and
//                   zstd-compressed (what HapticLab writes, see below);
//                   1 = the plain body (this layout, written until 0.2);
//                   0 = written before schema version 4, checksum added by
//                   the migration (see below); anything else is refused by
//                   number
//   bytes 1..4      CRC-32C (Castagnoli) of: first_tick as 8 bytes, count as
//                   8 bytes (the row's columns: a changed tick or count is
//                   caught too), byte 0, then the body (bytes 5..)
//   body, format 1: 28 channels, in the order of kChannelNames, each:
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
// compress well.
//
// Format 2's body is one zstd frame (level 1, content size in its header)
// of the format-1 body after a preconditioning for smooth signals: each
// channel stored per update with 4- or 8-byte values is replaced by the
// differences of consecutive bit patterns as unsigned integers (modulo
// 2^32 or 2^64, the first value as is) -- except dt_s when t_s is stored
// per update too, which becomes dt's bits XOR those of t's difference --
// and written as bit planes (db/README.md, "The chunk format", has the
// exact layout). Tags, constants and in_contact are unchanged. Decoding
// decompresses, undoes the planes and the differences and reads the
// format-1 layout: the values are bit-identical to format 1's. The
// checksum covers the compressed bytes, so damage is found without
// decompressing; a frame that does not decompress (written wrong) is
// reported like damage. About 28-38 instead of 76-86 bytes per
// instrument-sample (BENCHMARKS.md, issue 20 goal 2).
//
// Precision: t_s and dt_s are exact (float64). The physical channels are
// rounded to the nearest float32, a relative error of at most 2^-24 (6e-8):
// 6 nm on a 0.1 m position, 0.6 µN on a 10 N force, 0.2 µrad on 3 rad. A
// value beyond float32's range is stored as ±infinity; NaN stays NaN. The
// integer channels are exact.
//
// Format 0's body is a chunk blob as schema versions 1..3 wrote it: byte 1,
// then the channels as above. Its checksum only vouches for the bytes since
// the migration; damage done before it is caught only if it breaks the
// structure (size, tags).
//
// The chunk's first tick and count are columns of the row, not part of the
// blob; the ticks of a chunk are consecutive (first_tick + i).

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/common/crc32c.h"
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

inline constexpr std::uint8_t kChunkFormat = 2;        // what encode_chunk writes: compressed
inline constexpr std::uint8_t kChunkFormatPlain = 1;   // the uncompressed layout (still read)
inline constexpr std::uint8_t kChunkFormatMigrated = 0;  // checksummed by the schema 4 migration
inline constexpr std::size_t kChunkHeaderBytes = 5;     // format, CRC-32C
inline constexpr std::size_t kChunkChannels = 28;
// Most updates one chunk may hold (a damaged count never allocates more).
inline constexpr std::size_t kMaxChunkUpdates = std::size_t{1} << 20;
// Channel names in blob order; also the CSV column names (export_csv.h).
extern const std::array<const char*, kChunkChannels> kChannelNames;

// `samples`: 1..kMaxChunkUpdates, ticks consecutive; `format` kChunkFormat
// or kChunkFormatPlain (tests, and readers of old files, need the latter);
// throws std::invalid_argument otherwise. Returns a fresh blob. Not for the
// haptic loop's thread (it allocates); the writer thread calls it.
std::vector<std::byte> encode_chunk(std::span<const StoredSample> samples, std::uint8_t format = kChunkFormat);

// Why a stored chunk cannot be used. Derives from std::runtime_error so
// callers that only report it need nothing new.
class ChunkError : public std::runtime_error {
 public:
  enum class Kind { kChecksum, kUnknownFormat, kStructure };
  ChunkError(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  Kind kind() const noexcept { return kind_; }

 private:
  Kind kind_;
};

// Checks the header and the checksum only (no decoding); returns the
// format. Throws ChunkError: kStructure for a blob shorter than the header,
// kChecksum for a mismatch (tried first: a damaged format byte is damage),
// kUnknownFormat for a format other than 0, 1 and 2 whose checksum is right
// (a newer HapticLab wrote it).
std::uint8_t verify_chunk(std::uint64_t first_tick, std::size_t count, std::span<const std::byte> blob);

// Verifies (as verify_chunk), decodes a blob of `count` samples starting at
// `first_tick` and appends them to `out`. Throws ChunkError if the checksum,
// format or structure is wrong, or the size does not match `count` (a
// damaged row is refused, never guessed); `out` is then unchanged.
void decode_chunk(std::uint64_t first_tick, std::size_t count, std::span<const std::byte> blob,
                  std::vector<StoredSample>& out);

// A chunk blob of schema versions 1..3 as format 0: its bytes, unchanged,
// behind a header whose checksum is computed now (the schema 4 migration).
std::vector<std::byte> checksum_legacy_chunk(std::uint64_t first_tick, std::size_t count,
                                             std::span<const std::byte> legacy_blob);

// CRC-32C: core/common/crc32c.h (shared with the UDP bridge).
using hapticlab::crc32c;
using hapticlab::crc32c_portable;

// The value stored for a float32 channel: nearest float, ±inf beyond range.
float to_stored_float(double value) noexcept;

}  // namespace hapticlab::db
