#pragma once
// Streams one instrument's logged samples of a trial into a HandSeries, chunk
// by chunk, keeping only the channels the measures read (t_s, tip position,
// tip velocity, VE force). StudyDb::samples() returns every channel of every
// sample in one vector (about 230 bytes a sample): for a thesis-sized study
// that is gigabytes of allocation the analysis does not need. Read-only.
#include <cstdint>
#include <vector>

#include "analysis/metrics/trial_metrics.h"
#include "db/chunk_reader.h"
#include "db/sample_codec.h"

namespace hapticlab::db {
class StudyDb;
}

namespace hapticlab::analysis {

class HandSeriesReader {
 public:
  // Replaces `out` with the samples of (trial_id, instrument) in tick order.
  // A damaged chunk (checksum, format, structure: db/chunk_reader.h) is left
  // out and listed in bad_chunks(); throws db::DbError only for the database.
  void read(db::StudyDb& db, std::int64_t trial_id, int instrument, HandSeries& out);

  // The chunks the last read() left out.
  const std::vector<db::BadChunk>& bad_chunks() const noexcept { return bad_; }

 private:
  std::vector<db::StoredSample> chunk_;  // one decoded chunk, reused
  std::vector<db::BadChunk> bad_;
};

}  // namespace hapticlab::analysis
