#pragma once
// Reading sample chunks so that a damaged or misplaced one is left out and
// named, never decoded into wrong numbers: every read path (export,
// analysis, replay, `study check`, StudyDb::samples) goes through
// TrialChunks, which first lays out the trial's chunk rows (chunk_layout.h:
// instrument, ticks, no overlap) and then verifies each chunk's checksum
// and structure (sample_codec.h) as it reads it.
//
// Memory: a reader holds one chunk per instrument, in its plain layout (at
// most 117 bytes an update), and a window of at most kChunkWindow decoded
// samples per instrument; never a whole trial. What the reader's output
// needs (replay frames, a CSV line) is the caller's.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "db/chunk_layout.h"
#include "db/sample_codec.h"
#include "db/sqlite_handle.h"

namespace hapticlab::db {

// Samples decoded at a time per instrument (a chunk of the writer's 1000
// updates is one window).
inline constexpr std::size_t kChunkWindow = 4096;

class ReadSnapshot;  // chunk_reader.cc

// A window of one instrument's samples as columns (TrialChunks::
// next_columns): t_s and the float channels of the reader's set, in place
// in the chunk; the other channels' columns are empty (values nullptr).
struct ColumnWindow {
  std::size_t size = 0;
  const double* t_s = nullptr;  // size values, when t_s is in the set
  std::array<FloatColumn, kChunkChannels> channel{};
  bool empty() const noexcept { return size == 0; }
};

// One trial's chunks, read a window at a time per instrument.
class TrialChunks {
 public:
  // Reads the rows of the trial's chunks (not their blobs) and lays them
  // out; the misplaced ones are in bad() from the start. `only_instrument`
  // 0 or 1 reads and reports that instrument only; -1 both, and the chunks
  // of no known instrument. From here to the destructor the connection
  // holds a read transaction (when it held none), so the rows and the blobs
  // read later are one snapshot of the file, even while a session appends.
  // Throws DbError only for the database itself. `channels`: those the
  // caller reads (ChunkDecoder::load); in the samples next() gives, the
  // float channels outside the set are NaN, and the integer ones outside it
  // 0 (every chunk is still verified whole).
  TrialChunks(Database& db, std::int64_t trial_id, int only_instrument = -1, ChannelSet channels = kAllChannels);
  ~TrialChunks();
  TrialChunks(const TrialChunks&) = delete;
  TrialChunks& operator=(const TrialChunks&) = delete;

  // The next samples of instrument 0 or 1, in tick order; empty when it has
  // no more. A chunk that fails its checksum, format or structure is
  // skipped and added to bad(). Valid until the next call for the same
  // instrument.
  std::span<const StoredSample> next(int instrument);
  // The same samples as next() (the same bits), as columns: what analyze
  // reads, without copying every update into a StoredSample. Valid until
  // the next call for the same instrument (either call takes the window
  // after the last one given).
  ColumnWindow next_columns(int instrument);
  // The updates in the instrument's well-placed chunks (what next() gives
  // unless a chunk turns out damaged).
  std::size_t updates(int instrument) const noexcept { return layout_.updates[instrument]; }
  // Chunks left out: misplaced (from the start), then damaged (as met).
  const std::vector<BadChunk>& bad() const noexcept { return bad_; }

 private:
  struct Stream {
    std::size_t row = 0;  // next row of the layout to load
    std::size_t pos = 0;  // next sample of the loaded chunk
    ChunkDecoder chunk;
    std::vector<StoredSample> window;  // never shrinks: fields outside channels_ keep their blank
    std::vector<double> t_s;           // next_columns()'s
  };
  bool load_next(int instrument);

  Database& db_;
  std::unique_ptr<ReadSnapshot> snapshot_;  // first: ends last
  std::int64_t trial_id_;
  ChunkLayout layout_;
  std::vector<BadChunk> bad_;
  Statement blob_;
  ChannelSet channels_;
  StoredSample blank_;  // what a window's fields outside channels_ hold
  Stream stream_[2];
};

// The rows of one trial's chunks as read for the layout (chunk_rows_sql).
std::vector<ChunkRow> read_chunk_rows(Database& db, std::int64_t trial_id);

// Every sample of (trial, instrument) appended to `out`, in tick order; the
// instrument's chunks that cannot be used are appended to `bad` instead.
void read_samples(Database& db, std::int64_t trial_id, int instrument, std::vector<StoredSample>& out,
                  std::vector<BadChunk>& bad);

struct ChunkCheck {
  std::uint64_t chunks = 0;           // chunks checked
  std::uint64_t updates = 0;          // updates in the good ones
  std::uint64_t migrated_chunks = 0;  // good format 0 chunks: checksummed at migration, not when written
  std::vector<BadChunk> bad;
};

// Lays out, verifies and decodes (then discards) every chunk of the file,
// trial by trial, one chunk at a time.
ChunkCheck check_all_chunks(Database& db);

}  // namespace hapticlab::db
