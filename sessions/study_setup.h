#pragma once
// Puts a study into a database before any trial runs: the protocol text
// and hash, the participants (codes only), the full parameters of every
// setting, and every planned trial in schedule order.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "db/study_db.h"
#include "protocols/protocol.h"

namespace hapticlab::sessions {

struct CreatedStudy {
  std::int64_t study_id = 0;
  int participants = 0;
  int trials = 0;
  bool external_ve = false;  // the protocol says "ve": "external": run by the lab's application
  // Settings of the protocol that no participant's schedule holds (an
  // incomplete or explicit design with too few participants): they will not
  // be run, which the caller says. Empty for a staircase, whose strengths
  // are made during the sessions.
  std::vector<std::string> unscheduled_settings;
};

// Reads and validates the protocol file (ProtocolError), plans the study
// (design, block-randomized schedules) and stores it all in one
// transaction. Refuses (std::runtime_error) a database that already holds
// a study: one study per file keeps analysis and resumption unambiguous.
CreatedStudy create_study(db::StudyDb& db, const std::filesystem::path& protocol_file,
                          const std::string& software_version);

}  // namespace hapticlab::sessions
