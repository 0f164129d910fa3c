#include "analysis/learning/trial_table.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>
#include <sstream>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::learning {

const char* phase_name(Phase phase) {
  switch (phase) {
    case Phase::kPre: return "pre";
    case Phase::kTraining: return "training";
    case Phase::kPost: return "post";
    case Phase::kRetention: return "retention";
  }
  return "?";
}

TrialTable read_trial_table(const LongCsv& csv, const TrialColumns& columns) {
  const std::size_t c_participant = csv.column(columns.participant);
  const std::size_t c_group = csv.column(columns.group);
  const std::size_t c_phase = csv.column(columns.phase);
  const std::size_t c_trial = csv.column(columns.trial);
  const std::size_t c_measure = csv.column(columns.measure);
  TrialTable table;
  table.measure = columns.measure;
  std::map<std::string, std::size_t> index;
  std::set<std::string> groups;
  auto where = [&](std::size_t row, const std::string& column) {
    std::ostringstream m;
    m << csv.source() << " line " << csv.line(row) << " column " << column;
    return m.str();
  };
  for (std::size_t row = 0; row < csv.row_count(); ++row) {
    const std::string& id = csv.text(row, c_participant);
    const std::string& group = csv.text(row, c_group);
    if (id.empty()) throw DataError(where(row, columns.participant) + ": empty participant id (allowed: a non-empty id)");
    if (group.empty()) throw DataError(where(row, columns.group) + ": participant " + id + " has an empty group name (allowed: a non-empty name)");
    const std::string& phase_text = csv.text(row, c_phase);
    Phase phase;
    if (phase_text == "pre") phase = Phase::kPre;
    else if (phase_text == "training") phase = Phase::kTraining;
    else if (phase_text == "post") phase = Phase::kPost;
    else if (phase_text == "retention") phase = Phase::kRetention;
    else throw DataError(where(row, columns.phase) + ": phase '" + phase_text + "' (allowed: pre, training, post, retention)");
    const double trial = csv.number(row, c_trial);
    if (trial < 1.0 || trial != std::floor(trial) || trial > 1e9) {
      std::ostringstream m;
      m << where(row, columns.trial) << ": trial index " << trial << " (allowed: an integer >= 1)";
      throw DataError(m.str());
    }
    const double value = csv.number(row, c_measure);  // refuses empty, NaN, Inf by name
    auto [it, inserted] = index.emplace(id, table.participants.size());
    if (inserted) table.participants.push_back({id, group, {}});
    ParticipantTrials& p = table.participants[it->second];
    if (p.group != group) {
      throw DataError(where(row, columns.group) + ": participant " + id + " is in group '" + group +
                      "' here and in '" + p.group + "' earlier (allowed: one group per participant)");
    }
    groups.insert(group);
    PhaseTrials& t = p.phases[phase];
    t.trial.push_back(trial);
    t.value.push_back(value);
  }
  if (table.participants.empty()) throw DataError(csv.source() + ": no trials (allowed: at least one row)");
  for (auto& p : table.participants) {
    for (auto& entry : p.phases) {
      // Not a structured binding: clang 14 cannot capture one in the lambda.
      const Phase phase = entry.first;
      PhaseTrials& t = entry.second;
      std::vector<std::size_t> order(t.trial.size());
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return t.trial[a] < t.trial[b]; });
      PhaseTrials sorted;
      for (std::size_t i : order) {
        if (!sorted.trial.empty() && sorted.trial.back() == t.trial[i]) {
          std::ostringstream m;
          m << csv.source() << ": participant " << p.participant << " has trial " << t.trial[i] << " twice in phase "
            << phase_name(phase) << " (allowed: each trial index once)";
          throw DataError(m.str());
        }
        sorted.trial.push_back(t.trial[i]);
        sorted.value.push_back(t.value[i]);
      }
      t = std::move(sorted);
    }
  }
  table.groups.assign(groups.begin(), groups.end());
  return table;
}

}  // namespace hapticlab::analysis::learning
