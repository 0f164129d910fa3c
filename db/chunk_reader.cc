#include "db/chunk_reader.h"

#include "db/chunk_coverage.h"

#include <algorithm>
#include <limits>
#include <memory>

#include <sqlite3.h>

namespace hapticlab::db {
namespace {

BadChunk bad_chunk(const ChunkRow& r, const ChunkError& e) {
  return {r.trial_id, r.instrument, r.first_tick, r.count, e.kind(), e.what()};
}

}  // namespace

// A read transaction for the guard's life, when the connection holds none:
// the rows and the blobs read later are one snapshot of the file, even
// while a session appends to it or rewrites its open chunk.
class ReadSnapshot {
 public:
  explicit ReadSnapshot(Database& db) : db_(db) {
    if (sqlite3_get_autocommit(db.raw()) == 0) return;
    db.exec("BEGIN");
    own_ = true;
  }
  ~ReadSnapshot() {
    // Nothing to keep or undo; ending it lets the WAL be checkpointed past
    // this snapshot.
    if (own_) sqlite3_exec(db_.raw(), "ROLLBACK", nullptr, nullptr, nullptr);
  }
  ReadSnapshot(const ReadSnapshot&) = delete;
  ReadSnapshot& operator=(const ReadSnapshot&) = delete;

 private:
  Database& db_;
  bool own_ = false;
};

std::vector<ChunkRow> read_chunk_rows(Database& db, std::int64_t trial_id) {
  Statement s = db.prepare(chunk_rows_sql());
  s.bind(1, trial_id);
  std::vector<ChunkRow> rows;
  while (s.step()) {
    ChunkRow r;
    r.id = s.column_int64(0);
    r.trial_id = s.column_int64(1);
    r.instrument = s.column_int64(2);
    r.first_tick = s.column_int64(3);
    r.count = s.column_int64(4);
    for (int c = 0; c < 5; ++c) r.types[c] = s.column_text(5 + c);
    for (int c = 0; c < 4; ++c) r.values[c] = s.column_text(10 + c);
    rows.push_back(std::move(r));
  }
  return rows;
}

TrialChunks::TrialChunks(Database& db, std::int64_t trial_id, int only_instrument, ChannelSet channels)
    : db_(db),
      snapshot_(std::make_unique<ReadSnapshot>(db)),
      trial_id_(trial_id),
      blob_(db.prepare("SELECT data FROM sample_chunk WHERE id = ?1")),
      channels_(channels) {
  // A float channel nobody asked for reads NaN, never a plausible 0.
  for (std::size_t c = kChannelRawFirst; c < kChannelEngineStatus; ++c) {
    if ((channels & (ChannelSet{1} << c)) != 0) continue;
    InstrumentSample& v = blank_.value;
    const std::size_t k = c - kChannelRawFirst;
    double* field = k < 5 ? &v.raw_position[k] : k < 8 ? &v.degraded_position[k - 5]
                  : k < 11 ? &v.tip_position_m[k - 8] : k < 14 ? &v.tip_velocity_m_per_s[k - 11]
                  : k < 17 ? &v.ve_force_N[k - 14] : k < 20 ? &v.displayed_force_N[k - 17]
                  : &v.joint_force[k - 20];
    *field = std::numeric_limits<double>::quiet_NaN();
  }
  if ((channels & (ChannelSet{1} << kChannelT)) == 0) blank_.t_s = std::numeric_limits<double>::quiet_NaN();
  if ((channels & (ChannelSet{1} << kChannelDt)) == 0) blank_.dt_s = std::numeric_limits<double>::quiet_NaN();
  // Both instruments laid out and checked for what is missing (a chunk of
  // one that the other has, a gap no event explains), then the one asked for kept.
  layout_ = layout_chunks(read_chunk_rows(db, trial_id), bad_);
  if (bad_.empty()) check_chunk_coverage(db, trial_id, layout_, bad_);
  if (only_instrument == 0 || only_instrument == 1) {
    const int other = 1 - only_instrument;
    layout_.instrument[other].clear();
    layout_.updates[other] = 0;
    std::erase_if(bad_, [&](const BadChunk& b) { return b.instrument != only_instrument; });
  }
}

TrialChunks::~TrialChunks() = default;

bool TrialChunks::load_next(int instrument) {
  Stream& st = stream_[instrument];
  const std::vector<ChunkRow>& rows = layout_.instrument[instrument];
  while (st.row < rows.size()) {
    const ChunkRow& r = rows[st.row++];
    blob_.reset();
    blob_.bind(1, r.id);
    if (!blob_.step()) throw DbError(db_.path() + ": sample chunk row " + std::to_string(r.id) + " of trial " +
                                     std::to_string(trial_id_) + " vanished while it was read");
    try {
      st.chunk.load(r.place(), blob_.column_blob(0), channels_);
    } catch (const ChunkError& e) {
      bad_.push_back(bad_chunk(r, e));
      continue;
    }
    st.pos = 0;
    return true;
  }
  return false;
}

std::span<const StoredSample> TrialChunks::next(int instrument) {
  Stream& st = stream_[instrument];
  if (st.pos >= st.chunk.size() && !load_next(instrument)) return {};
  const std::size_t n = std::min(kChunkWindow, st.chunk.size() - st.pos);
  // read() writes the loaded channels only; the rest keep blank_'s values.
  if (st.window.size() < n) st.window.resize(n, blank_);
  st.chunk.read(st.pos, st.pos + n, st.window.data());
  st.pos += n;
  return std::span<const StoredSample>(st.window).first(n);
}

ColumnWindow TrialChunks::next_columns(int instrument) {
  Stream& st = stream_[instrument];
  if (st.pos >= st.chunk.size() && !load_next(instrument)) return {};
  ColumnWindow w;
  w.size = std::min(kChunkWindow, st.chunk.size() - st.pos);
  const ChannelSet read = st.chunk.channels();
  if ((read & (ChannelSet{1} << kChannelT)) != 0) {
    if (st.t_s.size() < w.size) st.t_s.resize(kChunkWindow);
    st.chunk.read_t(st.pos, st.pos + w.size, st.t_s.data());
    w.t_s = st.t_s.data();
  }
  for (std::size_t c = kChannelRawFirst; c < kChannelEngineStatus; ++c)
    if ((read & (ChannelSet{1} << c)) != 0) w.channel[c] = st.chunk.column(c, st.pos);
  st.pos += w.size;
  return w;
}

void read_samples(Database& db, std::int64_t trial_id, int instrument, std::vector<StoredSample>& out,
                  std::vector<BadChunk>& bad) {
  TrialChunks chunks(db, trial_id, instrument);
  out.reserve(out.size() + chunks.updates(instrument));
  for (std::span<const StoredSample> w = chunks.next(instrument); !w.empty(); w = chunks.next(instrument))
    out.insert(out.end(), w.begin(), w.end());
  bad.insert(bad.end(), chunks.bad().begin(), chunks.bad().end());
}

ChunkCheck check_all_chunks(Database& db) {
  ChunkCheck result;
  std::vector<std::int64_t> trials;
  const ReadSnapshot snapshot(db);
  {
    // Also the trials whose loop ran but that hold no chunk at all.
    Statement s = db.prepare(
        "SELECT trial_id FROM sample_chunk WHERE typeof(trial_id) = 'integer' UNION "
        "SELECT trial_id FROM loop_timing WHERE typeof(trial_id) = 'integer' ORDER BY trial_id");
    while (s.step()) trials.push_back(s.column_int64(0));
  }
  Statement blob = db.prepare("SELECT data FROM sample_chunk WHERE id = ?1");
  ChunkDecoder decoder;
  for (const std::int64_t trial : trials) {
    std::vector<ChunkRow> rows = read_chunk_rows(db, trial);
    result.chunks += rows.size();
    const std::size_t bad_before = result.bad.size();
    const ChunkLayout layout = layout_chunks(std::move(rows), result.bad);
    if (result.bad.size() == bad_before) check_chunk_coverage(db, trial, layout, result.bad);
    for (const auto& instrument : layout.instrument) {
      for (const ChunkRow& r : instrument) {
        blob.reset();
        blob.bind(1, r.id);
        if (!blob.step()) continue;
        try {
          decoder.load(r.place(), blob.column_blob(0));
        } catch (const ChunkError& e) {
          result.bad.push_back(bad_chunk(r, e));
          continue;
        }
        result.updates += decoder.size();
        if (decoder.format() == kChunkFormatMigrated) ++result.migrated_chunks;
      }
    }
  }
  return result;
}

}  // namespace hapticlab::db
