#pragma once
// The format-1 body of a sample chunk as channels (sample_codec.h has the
// layout), and format 3's two transforms of it -- the preconditioning
// (chunk_planes.cc) and the zstd frame (chunk_frame.cc) -- shared by the
// codec's parts; not for use outside db/.

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "db/sample_codec.h"

namespace hapticlab::db::chunk {

enum Tag : std::uint8_t { kPerUpdate = 0, kConstant = 1, kRunningSum = 2 };

// Channels in blob order: dt_s, t_s, the float32 ones, then the status
// words and in_contact.
constexpr std::size_t kFirstFloat = 2, kEndFloat = 25;
constexpr std::size_t kEngineStatus = 25, kDeviceStatus = 26, kInContact = 27;

// Bytes per value of each channel, in blob order (t_s's running-sum tag
// is followed by one 8-byte value, like a constant).
constexpr int channel_bytes(std::size_t channel) noexcept {
  return channel < kFirstFloat ? 8 : channel == kInContact ? 1 : 4;
}

struct Segment {
  std::uint8_t tag = kConstant;
  std::byte* values = nullptr;  // the channel's first value
  std::size_t width = 0;        // bytes per value
};

// The channels of a format-1 body of `n` updates; `end` (if given) gets the
// offset just past the last one. Throws ChunkError (kStructure) for a body
// too short for its count or a channel with an unknown tag.
std::array<Segment, kChunkChannels> segments(std::span<std::byte> body, std::size_t n, std::size_t* end = nullptr);

// A format-1 body of `n` updates that holds exactly its channels. Returns
// the channels' layout; throws ChunkError (kStructure) otherwise.
std::array<Segment, kChunkChannels> exact_segments(std::span<std::byte> body, std::size_t n);

template <typename U>
U load(const std::byte* p) noexcept {
  U v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// The worst-case format-1 body of n updates: 28 tags, every channel per
// update (t_s's running sum is smaller).
constexpr std::size_t kBytesPerUpdate = 8 + 8 + 4 * (kEndFloat - kFirstFloat) + 4 + 4 + 1;
constexpr std::size_t max_body_bytes(std::size_t n) noexcept { return kChunkChannels + n * kBytesPerUpdate; }

inline ChunkError structure(const std::string& what) { return ChunkError(ChunkError::Kind::kStructure, what); }

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
// `only`: undoing (forward false), the channels to restore; the others are
// left preconditioned (a reader that projects never reads them).
void precondition(std::span<std::byte> body, std::size_t n, bool forward, std::vector<std::byte>& scratch,
                  ChannelSet only = kAllChannels);

// A plain body (preconditioned) as one zstd frame -- level 1, its content
// size and content checksum in it -- behind room for the 5-byte header.
std::vector<std::byte> compress_body(std::span<const std::byte> plain);

// A chunk's zstd frame, checked before anything is allocated for it: one
// frame that states its content size, at most `most` bytes (what the row's
// count of updates can take), with the content checksum flag when
// `need_checksum`, and nothing after it. Returns the content size; throws
// ChunkError (kStructure) naming what is wrong.
std::size_t check_frame(std::span<const std::byte> frame, std::size_t most, bool need_checksum);

// The checked frame decompressed into `out` (its content checksum, when it
// has one, verified by zstd).
void decompress(std::span<const std::byte> frame, std::size_t size, std::vector<std::byte>& out);

}  // namespace hapticlab::db::chunk
