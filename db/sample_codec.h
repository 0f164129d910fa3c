#pragma once
// Sample chunks: up to a few thousand consecutive updates of one instrument
// packed into one BLOB (one row of sample_chunk), about 8x smaller and far
// faster to write than a row per sample.
//
// Layout, all numbers little-endian. A 5-byte header, the same for every
// format, so a checksum can be verified without decoding:
//
//   byte 0          format: 3 = the format-1 body, preconditioned and
//                   zstd-compressed, the frame with its content checksum
//                   (what HapticLab writes, see below);
//                   1 = the plain body (this layout, written until 0.2);
//                   0 = written before schema version 4, checksum added by
//                   the migration (see below); 2 = format 3 without the
//                   frame's content checksum (schemas 4..6; the migration to
//                   schema 7 converts it, so a current file holds none);
//                   anything else is refused by number
//   bytes 1..4      CRC-32C (Castagnoli) of where the chunk belongs -- the
//                   row's trial_id, instrument, first_tick and count, 8
//                   bytes each -- then byte 0, then the body (bytes 5..).
//                   A chunk moved to another trial or instrument, shifted
//                   in time or given another count no longer verifies.
//                   (Schemas 4..6 left trial and instrument out; the
//                   migration to 7 recomputes every checksum.)
//   body, format 1: 28 channels, in the order of kChannelNames, each:
//     1 byte tag    0 = `count` values follow, one per update, in order
//                   1 = one value follows, the same for every update
//                   2 = (t_s only) one float64 t[0] follows; the rest are
//                       t[i] = t[i-1] + dt[i] in float64, which the encoder
//                       checked is bit-exact before choosing this tag
//     values        float64 (t_s, dt_s), uint32 (engine_status), int32
//                   (device_status), uint8 0/1 (in_contact), float32 (the
//                   23 other channels)
//                   and nothing after the last channel.
//
// Column-major (channel after channel) so equal channels collapse to one
// value (forces out of contact, unused joints, status words) and the rest
// compress well.
//
// Format 3's body is one zstd frame (level 1, content size and content
// checksum in its header and trailer, nothing after it) of the format-1
// body after a preconditioning for smooth signals: each
// channel stored per update with 4- or 8-byte values is replaced by the
// differences of consecutive bit patterns as unsigned integers (modulo
// 2^32 or 2^64, the first value as is) -- except dt_s when t_s is stored
// per update too, which becomes dt's bits XOR those of t's difference --
// and written as bit planes (db/README.md, "The chunk format", has the
// exact layout). Tags, constants and in_contact are unchanged. Decoding
// decompresses, undoes the planes and the differences and reads the
// format-1 layout: the values are bit-identical to format 1's. The CRC
// covers the compressed bytes, so damage is found without decompressing;
// the frame's own checksum (XXH64 of the decompressed body) catches a
// frame changed with its CRC recomputed, and its content size is checked
// against `count` before anything is allocated (a small frame cannot make
// a reader allocate more than the chunk's declared updates need). A frame
// that does not decompress is reported like damage. About 28-38 instead of
// 76-86 bytes per instrument-sample (BENCHMARKS.md, issue 20 goal 2).
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
// The chunk's trial, instrument, first tick and count are columns of the
// row, not part of the blob; the ticks of a chunk are consecutive
// (first_tick + i). Whether the chunks of a trial fit together (no overlap,
// a known instrument) is chunk_layout.h's.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/common/crc32c.h"
#include "core/loop/loop_sample.h"
#include "db/float_column.h"

namespace hapticlab::db {

// One update of one instrument as stored and read back.
struct StoredSample {
  std::uint64_t tick = 0;
  double t_s = 0.0;   // loop clock at the start of the update [s]
  double dt_s = 0.0;  // measured period [s]
  std::int32_t device_status = 0;
  InstrumentSample value;  // units as in core/loop/loop_sample.h
};

inline constexpr std::uint8_t kChunkFormat = 3;          // what encode_chunk writes: compressed, frame checksummed
inline constexpr std::uint8_t kChunkFormatSchema6 = 2;   // compressed, no frame checksum: schemas 4..6 only
inline constexpr std::uint8_t kChunkFormatPlain = 1;     // the uncompressed layout (still read)
inline constexpr std::uint8_t kChunkFormatMigrated = 0;  // checksummed by the schema 4 migration
inline constexpr std::size_t kChunkHeaderBytes = 5;      // format, CRC-32C
inline constexpr std::size_t kChunkChannels = 28;
// Most updates one chunk may hold (a damaged count never allocates more).
inline constexpr std::size_t kMaxChunkUpdates = std::size_t{1} << 20;
// Channel names in blob order; also the CSV column names (export_csv.h).
extern const std::array<const char*, kChunkChannels> kChannelNames;

// A set of channels, bit c for channel c of kChannelNames: what a reader
// needs of a chunk (column projection). ChunkDecoder then undoes the
// preconditioning of those channels only and read() writes those only; a
// chunk is still verified whole (checksum, frame, every channel's layout).
using ChannelSet = std::uint32_t;
inline constexpr ChannelSet kAllChannels = (ChannelSet{1} << kChunkChannels) - 1;
// Channel numbers (kChannelNames' order) of the first of each group.
inline constexpr std::size_t kChannelDt = 0, kChannelT = 1, kChannelRawFirst = 2, kChannelTipFirst = 10,
                             kChannelTipVelocityFirst = 13, kChannelVeForceFirst = 16,
                             kChannelDisplayedForceFirst = 19, kChannelJointForceFirst = 22,
                             kChannelEngineStatus = 25, kChannelDeviceStatus = 26, kChannelInContact = 27;
// Channels first .. first + n - 1.
constexpr ChannelSet channel_range(std::size_t first, std::size_t n) noexcept {
  return ((ChannelSet{1} << n) - 1) << first;
}

// Where a chunk belongs: its row's columns, which its checksum covers.
struct ChunkPlace {
  std::int64_t trial_id = 0;
  std::int64_t instrument = 0;  // 0 left, 1 right
  std::uint64_t first_tick = 0;
  std::uint64_t count = 0;  // updates: first_tick .. first_tick + count - 1
};

// `samples`: 1..kMaxChunkUpdates, ticks consecutive; `format` kChunkFormat
// or kChunkFormatPlain (tests, and readers of old files, need the latter);
// throws std::invalid_argument otherwise. The checksum covers `trial_id`,
// `instrument` and the samples' ticks. Returns a fresh blob. Not for the
// haptic loop's thread (it allocates); the writer thread calls it.
std::vector<std::byte> encode_chunk(std::int64_t trial_id, int instrument, std::span<const StoredSample> samples,
                                    std::uint8_t format = kChunkFormat);

// Why a stored chunk cannot be used. Derives from std::runtime_error so
// callers that only report it need nothing new. kPlacement: the chunk's row
// does not fit with the trial's other chunks (chunk_layout.h).
class ChunkError : public std::runtime_error {
 public:
  enum class Kind { kChecksum, kUnknownFormat, kStructure, kPlacement };
  ChunkError(Kind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  Kind kind() const noexcept { return kind_; }

 private:
  Kind kind_;
};
// "checksum", "format", "structure", "placement" (for JSON and Python).
const char* to_string(ChunkError::Kind kind) noexcept;

// Checks the header and the checksum only (no decoding); returns the
// format. Throws ChunkError: kStructure for a blob shorter than the header
// or a count outside 1..kMaxChunkUpdates, kChecksum for a mismatch (tried
// before the format: a damaged format byte is damage), kStructure for
// format 2 (converted by the migration to schema 7, so never in a current
// file), kUnknownFormat for another format whose checksum is right (a newer
// HapticLab wrote it).
std::uint8_t verify_chunk(const ChunkPlace& place, std::span<const std::byte> blob);

// A verified chunk ready to be read a window at a time: load() checks and
// unpacks the blob into the plain layout (the only copy held: at most 117
// bytes an update, a format-3 frame's content size checked against that
// before decompressing); read() then makes StoredSamples of any range.
// Readers that stream hold one of these per instrument instead of a whole
// chunk of StoredSamples (224 bytes an update). Reusable: buffers are kept.
class ChunkDecoder {
 public:
  // Verifies (as verify_chunk), decompresses (format 3: one frame, its
  // content checksum verified, nothing after it) and checks that the body
  // holds exactly `place.count` updates of every channel. Throws ChunkError;
  // the decoder is then empty (size() 0). `blob` is not kept.
  // `channels`: those read() will be asked for (t_s's running sum brings
  // dt_s along, a residual dt_s brings t_s); read() leaves every other field
  // of its output as it was.
  void load(const ChunkPlace& place, std::span<const std::byte> blob, ChannelSet channels = kAllChannels);
  // load() without keeping the result in a readable form: every check of
  // load(), for readers that verify a trial's chunks before using any.
  void check(const ChunkPlace& place, std::span<const std::byte> blob);
  std::size_t size() const noexcept { return count_; }
  std::uint8_t format() const noexcept { return format_; }
  // Samples begin .. end - 1 of the chunk (end <= size()) into out[0 ..
  // end - begin - 1], ticks first_tick + i; only the loaded channels (and
  // the tick). Cheapest in increasing order.
  void read(std::size_t begin, std::size_t end, StoredSample* out) noexcept;
  // The channels read() writes (load()'s, with what they depend on).
  ChannelSet channels() const noexcept { return channels_read_; }
  // Without copying into StoredSample, for readers that take a few channels
  // of many updates (analyze): float channel c (kChannelRawFirst <= c <
  // kChannelEngineStatus, one of channels()) from update `begin` on, the
  // same values read() gives; valid until the next load().
  FloatColumn column(std::size_t c, std::size_t begin) const noexcept;
  // t_s of updates begin .. end - 1 into out[0 .. end - begin - 1], as
  // read() gives them (kChannelT must be in channels()).
  void read_t(std::size_t begin, std::size_t end, double* out) noexcept;

 private:
  struct Channel {
    std::uint8_t tag = 0;
    std::size_t offset = 0;  // of the channel's first value in body_
  };
  void unpack(const ChunkPlace& place, std::span<const std::byte> blob, bool readable, ChannelSet channels);
  // t_s of updates begin .. begin + n - 1, to set(i, t).
  template <typename Set>
  void times(std::size_t begin, std::size_t n, Set set) noexcept;

  std::vector<std::byte> body_;  // the plain layout (format 0: after its legacy byte)
  std::vector<std::byte> scratch_;
  std::array<Channel, kChunkChannels> channels_{};
  std::uint64_t first_tick_ = 0;
  std::size_t count_ = 0;
  std::uint8_t format_ = 0;
  ChannelSet channels_read_ = kAllChannels;
  // t_s as a running sum: the next index to sum and the t before it.
  std::size_t t_next_ = 0;
  double t_prev_ = 0.0;
};

// Verifies, decodes a blob of `place.count` samples and appends them to
// `out`. Throws ChunkError if the checksum, format or structure is wrong
// (a damaged row is refused, never guessed); `out` is then unchanged.
void decode_chunk(const ChunkPlace& place, std::span<const std::byte> blob, std::vector<StoredSample>& out);

// The same chunk given a new place (a study merge renumbers trials): first
// verified in full at `from` (ChunkDecoder::check: checksum, format, frame
// and its content checksum, exact structure), then its checksum recomputed
// over `to`; every other byte kept. `to` must hold the same first tick and
// count (std::invalid_argument otherwise: only trial and instrument may
// move). Throws ChunkError if the chunk is damaged at `from`: a damaged
// chunk is never given a checksum that vouches for it.
std::vector<std::byte> move_chunk(const ChunkPlace& from, const ChunkPlace& to, std::span<const std::byte> blob);

// --- older schemas, for the migrations (schema.cc) and their tests

// A chunk blob of schema versions 1..3 as format 0: its bytes, unchanged,
// behind a header whose checksum (schema 4's: first_tick, count, format,
// body) is computed now (the schema 4 migration).
std::vector<std::byte> checksum_legacy_chunk(std::uint64_t first_tick, std::size_t count,
                                             std::span<const std::byte> legacy_blob);

// A chunk as schemas 4..6 stored it (formats 0, 1 and 2; the checksum over
// first_tick, count, format and body) as schema 7 stores it: the schema-6
// checksum verified and the chunk decoded in full first, then format 2's
// frame recompressed with its content checksum as format 3 (formats 0 and 1
// keep their body), and the checksum computed over `place`. Throws
// ChunkError if the chunk does not verify or decode as schema 6 read it
// (the migration then keeps it unchanged, so it stays damaged).
std::vector<std::byte> upgrade_schema6_chunk(const ChunkPlace& place, std::span<const std::byte> blob);

// CRC-32C: core/common/crc32c.h (shared with the UDP bridge).
using hapticlab::crc32c;
using hapticlab::crc32c_portable;

// The value stored for a float32 channel: nearest float, ±inf beyond range.
float to_stored_float(double value) noexcept;

}  // namespace hapticlab::db
