#pragma once
// Streams one instrument's logged samples of a trial into a HandSeries, chunk
// by chunk, keeping only the channels the measures read (t_s, tip position,
// tip velocity, VE force). StudyDb::samples() returns every channel of every
// sample in one vector (about 230 bytes a sample): for a thesis-sized study
// that is gigabytes of allocation the analysis does not need. Read-only.
#include <cstdint>
#include <vector>

#include "analysis/metrics/trial_metrics.h"
#include "db/sample_codec.h"

namespace hapticlab::db {
class StudyDb;
}

namespace hapticlab::analysis {

class HandSeriesReader {
 public:
  // Replaces `out` with the samples of (trial_id, instrument) in tick order.
  // Throws db::DbError naming the trial, instrument and chunk for a damaged
  // chunk.
  void read(db::StudyDb& db, std::int64_t trial_id, int instrument, HandSeries& out);

 private:
  std::vector<db::StoredSample> chunk_;  // one decoded chunk, reused
};

}  // namespace hapticlab::analysis
