#include "analysis/study/sample_reader.h"

#include <span>

#include "db/study_db.h"

namespace hapticlab::analysis {

void HandSeriesReader::read(db::StudyDb& db, std::int64_t trial_id, int instrument, HandSeries& out) {
  out.clear();
  bad_.clear();
  db::for_each_chunk(db.connection(), trial_id, instrument, chunk_,
                     [&](std::span<const db::StoredSample> chunk) {
                       for (const db::StoredSample& x : chunk)
                         out.push_back(x.t_s, x.value.tip_position_m, x.value.tip_velocity_m_per_s,
                                       x.value.ve_force_N);
                     },
                     bad_);
}

}  // namespace hapticlab::analysis
