#include "sessions/study_progress.h"

#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>

#include <nlohmann/json.hpp>

#include "protocols/group_assignment.h"
#include "protocols/protocol_json.h"
#include "protocols/sittings.h"

namespace hapticlab::sessions {
namespace {

// A sitting is done when none of its trials (block = sitting) is still
// planned or running; re-queued trials keep it open.
void add_sitting_progress(const db::StudyRow& study, std::vector<ParticipantProgress>& participants) {
  const auto design = protocols::group_design_from_protocol_text(study.protocol_json, "stored protocol");
  if (!design) return;
  const std::string source = "stored protocol of \"" + study.name + "\"";
  const auto groups = protocols::assign_groups(*design, source);
  for (ParticipantProgress& p : participants) {
    std::size_t index = 0;
    while (index < design->participants.size() && design->participants[index].code != p.code) ++index;
    if (index == design->participants.size()) continue;
    const auto sittings = protocols::group_sittings(*design, groups[index]);
    std::vector<bool> open(sittings.size() + 1, false);
    std::vector<std::optional<double>> end(sittings.size() + 1);
    for (const db::TrialRow& t : p.trials) {
      if (t.block < 1 || static_cast<std::size_t>(t.block) > sittings.size()) continue;
      if (t.status == db::TrialStatus::kPlanned || t.status == db::TrialStatus::kRunning) open[t.block] = true;
      if (t.ended_unix_s && (!end[t.block] || *t.ended_unix_s > *end[t.block])) end[t.block] = t.ended_unix_s;
    }
    std::size_t done = 0;
    while (done < sittings.size() && !open[done + 1]) ++done;
    const auto due = protocols::next_sitting_due(sittings, done, done == 0 ? std::nullopt : end[done]);
    SittingProgress sp;
    sp.group = design->transfer->groups[groups[index]].name;
    sp.sittings_done = static_cast<int>(done);
    sp.sittings = static_cast<int>(sittings.size());
    if (due.next < sittings.size()) {
      sp.next_phase = std::string(protocols::phase_kind_name(sittings[due.next].phase));
      sp.next_session = sittings[due.next].session;
    } else {
      sp.next_phase = "done";
    }
    sp.due_unix_s = due.due_unix_s;
    p.sitting = std::move(sp);
  }
}

std::string due_text(const SittingProgress& sp) {
  if (sp.next_phase == "done") return "-";
  return sp.due_unix_s ? protocols::utc_text(*sp.due_unix_s) : "now";
}

}  // namespace

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
  add_sitting_progress(out.study, out.participants);
  out.conditions = analysis::read_session_conditions(db, out.study.id);
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
  if (!progress.conditions.rate_text.starts_with("not recorded")) {
    s += "sessions: loop rate " + progress.conditions.rate_text + "; who held the device: " +
         progress.conditions.participant_text + "\n";
  }
  for (const std::string& w : progress.conditions.warnings) s += "warning: " + w + "\n";
  bool grouped = false;
  for (const auto& p : progress.participants) grouped = grouped || p.sitting.has_value();
  if (grouped) {
    std::snprintf(line, sizeof line, "\n%-12s %-28s %-9s %-16s %s\n", "participant", "group", "sittings",
                  "next", "due (UTC)");
    s += line;
    for (const auto& p : progress.participants) {
      if (!p.sitting) continue;
      const SittingProgress& sp = *p.sitting;
      const std::string next =
          sp.next_phase == "done" ? "done" : sp.next_phase + " " + std::to_string(sp.next_session);
      const std::string count = std::to_string(sp.sittings_done) + "/" + std::to_string(sp.sittings);
      std::snprintf(line, sizeof line, "%-12s %-28s %-9s %-16s %s\n", p.code.c_str(), sp.group.c_str(),
                    count.c_str(), next.c_str(), due_text(sp).c_str());
      s += line;
    }
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
  j["sessions"] = {{"rate", progress.conditions.rate_text},
                   {"who_held_the_device", progress.conditions.participant_text},
                   {"warnings", progress.conditions.warnings}};
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
    if (p.sitting) {
      const SittingProgress& sp = *p.sitting;
      j["participants"].back()["group"] = sp.group;
      j["participants"].back()["sittings_done"] = sp.sittings_done;
      j["participants"].back()["sittings"] = sp.sittings;
      j["participants"].back()["next_phase"] = sp.next_phase;
      j["participants"].back()["next_session"] = sp.next_session;
      j["participants"].back()["next_due_utc"] = due_text(sp);
    }
  }
  return j;
}

}  // namespace hapticlab::sessions
