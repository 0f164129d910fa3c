#include "db/chunk_coverage.h"

#include <map>

#include "db/chunk_coverage_rules.h"

namespace hapticlab::db {

void check_chunk_coverage(Database& db, std::int64_t trial_id, const ChunkLayout& layout, std::vector<BadChunk>& bad,
                          const char* schema) {
  std::map<std::int64_t, std::int64_t> logged;
  {
    Statement s = db.prepare(logged_gaps_sql(schema));
    s.bind(1, trial_id);
    while (s.step()) ++logged[s.column_int64(0)];
  }
  LoopCount loop;
  {
    Statement s = db.prepare(loop_count_sql(schema));
    s.bind(1, trial_id);
    if (s.step()) loop = loop_count(s.column_int64(0), s.column_int64(1), s.column_int64(2));
  }
  add_coverage_findings(trial_id, layout, logged, loop, bad);
}

}  // namespace hapticlab::db
