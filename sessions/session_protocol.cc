#include "sessions/session_protocol.h"

#include <stdexcept>

#include <nlohmann/json.hpp>

#include "db/sqlite_handle.h"

namespace hapticlab::sessions {

// The protocol's training trials for `code`: the participant entry's
// training_trials, else the top-level one, else 0. The stored protocol was
// validated when the study was created, so only the shape is read here.
int protocol_training_trials(const std::string& protocol_json, const std::string& code) {
  const nlohmann::json j = nlohmann::json::parse(protocol_json);
  int trials = j.value("training_trials", 0);
  for (const nlohmann::json& p : j.at("participants")) {
    if (p.is_object() && p.value("code", std::string()) == code) trials = p.value("training_trials", trials);
  }
  return trials;
}

// The setting simulated participants train under: the protocol's first
// (the control, High Fidelity in the thesis).
std::int64_t training_setting_id(db::StudyDb& db, std::int64_t study_id) {
  db::Statement q = db.connection().prepare("SELECT id FROM setting WHERE study_id = ? ORDER BY id LIMIT 1");
  q.bind(1, study_id);
  if (!q.step()) throw std::runtime_error(db.path() + ": the study has no settings");
  return q.column_int64(0);
}

// The simulated rig has only its own VE's tasks: a study whose protocol
// declares an external VE (its tasks are the lab's own) is run by the lab's
// application through the study API. Refused before the session begins.
void refuse_external_ve(const db::StudyRow& study) {
  const nlohmann::json j = nlohmann::json::parse(study.protocol_json);
  if (j.is_object() && j.value("ve", std::string("simulated")) == "external")
    throw std::runtime_error("study '" + study.name +
                             "': its protocol declares \"ve\": \"external\", so its tasks run in the lab's own "
                             "VE; `session run` drives only the simulated VE (tasks dissection and clip). Run the "
                             "study from the lab's application through the study API (hapticlab/study.h, see "
                             "docs/ve_events.md).");
}

}  // namespace hapticlab::sessions
