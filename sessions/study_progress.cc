#include "sessions/study_progress.h"

#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>

#include <nlohmann/json.hpp>

namespace hapticlab::sessions {

StudyProgress study_progress(db::StudyDb& db) {
  const auto studies = db.studies();
  if (studies.empty()) throw std::runtime_error(db.path() + ": holds no study (run `hapticlab study create` first)");
  StudyProgress out;
  out.study = studies.front();
  std::map<std::string, ParticipantProgress> by_code;
  for (const db::TrialRow& t : db.trials(out.study.id)) {
    ParticipantProgress& p = by_code[t.participant_code];
    p.code = t.participant_code;
    p.trials.push_back(t);
    switch (t.status) {
      case db::TrialStatus::kPlanned: ++p.planned; break;
      case db::TrialStatus::kRunning: ++p.running; break;
      case db::TrialStatus::kComplete: ++p.complete; break;
      case db::TrialStatus::kAborted: ++p.aborted; break;
    }
  }
  for (auto& [code, p] : by_code) {
    // A re-queued trial repeats a (task, setting, repetition) slot; the
    // original schedule has each slot once.
    std::set<std::tuple<std::string, std::int64_t, int>> slots;
    for (const auto& t : p.trials) slots.emplace(t.task, t.setting_id, t.repetition);
    p.scheduled = static_cast<int>(slots.size());
    out.participants.push_back(std::move(p));
  }
  return out;
}

std::string format_study_progress(const StudyProgress& progress, bool with_schedule) {
  std::string s;
  char line[256];
  std::snprintf(line, sizeof line, "study: %s (seed %llu, protocol sha256 %.12s..., created %s)\n",
                progress.study.name.c_str(), static_cast<unsigned long long>(progress.study.seed),
                progress.study.protocol_sha256.c_str(), progress.study.created_utc.c_str());
  s += line;
  std::snprintf(line, sizeof line, "%-12s %9s %8s %8s %8s %8s\n", "participant", "scheduled", "complete",
                "aborted", "running", "to do");
  s += line;
  for (const auto& p : progress.participants) {
    std::snprintf(line, sizeof line, "%-12s %9d %8d %8d %8d %8d\n", p.code.c_str(), p.scheduled, p.complete,
                  p.aborted, p.running, p.planned);
    s += line;
  }
  if (!with_schedule) return s;
  for (const auto& p : progress.participants) {
    s += "\n" + p.code + ":\n";
    std::snprintf(line, sizeof line, "  %4s %-10s %-22s %4s %5s %-9s %s\n", "pos", "task", "setting", "rep",
                  "block", "status", "note");
    s += line;
    for (const auto& t : p.trials) {
      std::snprintf(line, sizeof line, "  %4d %-10s %-22s %4d %5d %-9s %s\n", t.position, t.task.c_str(),
                    t.setting_name.c_str(), t.repetition, t.block, db::to_string(t.status),
                    t.abort_reason.c_str());
      s += line;
    }
  }
  return s;
}

nlohmann::json study_progress_json(const StudyProgress& progress) {
  nlohmann::json j;
  j["study"] = {{"id", progress.study.id},
                {"name", progress.study.name},
                {"seed", progress.study.seed},
                {"protocol_sha256", progress.study.protocol_sha256},
                {"software_version", progress.study.software_version},
                {"created_utc", progress.study.created_utc}};
  j["participants"] = nlohmann::json::array();
  for (const auto& p : progress.participants) {
    nlohmann::json trials = nlohmann::json::array();
    for (const auto& t : p.trials) {
      nlohmann::json tj = {{"id", t.id},           {"position", t.position}, {"task", t.task},
                           {"setting", t.setting_name}, {"repetition", t.repetition}, {"block", t.block},
                           {"status", db::to_string(t.status)}};
      if (!t.abort_reason.empty()) tj["abort_reason"] = t.abort_reason;
      trials.push_back(std::move(tj));
    }
    j["participants"].push_back({{"code", p.code},
                                 {"scheduled", p.scheduled},
                                 {"complete", p.complete},
                                 {"aborted", p.aborted},
                                 {"running", p.running},
                                 {"to_do", p.planned},
                                 {"trials", std::move(trials)}});
  }
  return j;
}

}  // namespace hapticlab::sessions
