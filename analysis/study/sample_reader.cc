#include "analysis/study/sample_reader.h"

#include <stdexcept>
#include <string>

#include "db/study_db.h"

namespace hapticlab::analysis {

void HandSeriesReader::read(db::StudyDb& db, std::int64_t trial_id, int instrument, HandSeries& out) {
  out.clear();
  bad_.clear();
  // The same query as StudyDb::samples(): chunks in tick order.
  db::Statement s = db.connection().prepare(
      "SELECT first_tick, count, data FROM sample_chunk WHERE trial_id = ?1 AND instrument = ?2 ORDER BY first_tick");
  s.bind(1, trial_id).bind(2, std::int64_t{instrument});
  while (s.step()) {
    const auto first = static_cast<std::uint64_t>(s.column_int64(0));
    const std::int64_t count = s.column_int64(1);
    chunk_.clear();
    try {
      db::decode_chunk(first, static_cast<std::size_t>(count), s.column_blob(2), chunk_);
    } catch (const db::ChunkError& e) {
      bad_.push_back({trial_id, instrument, first, static_cast<std::uint64_t>(count), e.kind(), e.what()});
      continue;
    }
    for (const db::StoredSample& x : chunk_) {
      out.push_back(x.t_s, x.value.tip_position_m, x.value.tip_velocity_m_per_s, x.value.ve_force_N);
    }
  }
}

}  // namespace hapticlab::analysis
