#pragma once
// What a study's stored protocol says for its simulated sessions, read by
// the session runner: the training trials per participant, the setting
// training runs under, and whether the simulated rig can run the study at
// all (an external VE's study is the lab's application's).

#include <cstdint>
#include <string>

#include "db/study_db.h"

namespace hapticlab::sessions {

// The protocol's training trials for `code`: the participant entry's
// training_trials, else the top-level one, else 0.
int protocol_training_trials(const std::string& protocol_json, const std::string& code);

// The setting simulated participants train under: the protocol's first
// (the control, High Fidelity in the thesis). Throws std::runtime_error
// for a study without settings.
std::int64_t training_setting_id(db::StudyDb& db, std::int64_t study_id);

// Throws std::runtime_error, saying what to do, for a study whose protocol
// declares an external VE.
void refuse_external_ve(const db::StudyRow& study);

}  // namespace hapticlab::sessions
