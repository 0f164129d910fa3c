#include "analysis/study/group_design.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "analysis/learning/learning_figures.h"
#include "analysis/stats/data_error.h"
#include "core/common/csv_format.h"
#include "core/common/output_file.h"
#include "protocols/group_assignment.h"
#include "protocols/sittings.h"

namespace hapticlab::analysis {
namespace {

learning::Phase learning_phase(protocols::PhaseKind kind) {
  switch (kind) {
    case protocols::PhaseKind::kPreTest: return learning::Phase::kPre;
    case protocols::PhaseKind::kTraining: return learning::Phase::kTraining;
    case protocols::PhaseKind::kPostTest: return learning::Phase::kPost;
    case protocols::PhaseKind::kRetention: return learning::Phase::kRetention;
  }
  return learning::Phase::kPre;
}

// Each participant's group and sittings, by code.
struct Member {
  std::string group;
  std::vector<protocols::Sitting> sittings;
};

std::map<std::string, Member> members_of(const protocols::Protocol& p) {
  const std::vector<std::size_t> groups = protocols::assign_groups(p, "the study's protocol");
  std::map<std::string, Member> out;
  for (std::size_t i = 0; i < p.participants.size(); ++i)
    out[p.participants[i].code] = {p.transfer->groups[groups[i]].name, protocols::group_sittings(p, groups[i])};
  return out;
}

// The task's complete trials as the learning analyses' table, trials in
// schedule order and numbered 1, 2, ... within each participant's phase.
learning::TrialTable table_of(const StudyAnalysis& a, const std::string& task, const std::map<std::string, Member>& members) {
  std::vector<const TrialRecord*> trials;
  for (const TrialRecord& t : a.trials)
    if (t.task == task && t.status == "complete" && t.window) trials.push_back(&t);
  std::stable_sort(trials.begin(), trials.end(), [](const TrialRecord* x, const TrialRecord* y) {
    return x->participant != y->participant ? x->participant < y->participant : x->position < y->position;
  });
  learning::TrialTable table;
  table.measure = "completion_time_s";
  std::set<std::string> groups;
  for (const TrialRecord* t : trials) {
    const auto m = members.find(t->participant);
    if (m == members.end()) throw DataError("group design: trial " + std::to_string(t->trial_id) + "'s participant " +
                                            t->participant + " is not in the protocol");
    const std::vector<protocols::Sitting>& sittings = m->second.sittings;
    if (t->block < 1 || static_cast<std::size_t>(t->block) > sittings.size())
      throw DataError("group design: trial " + std::to_string(t->trial_id) + " is in sitting " +
                      std::to_string(t->block) + ", but " + t->participant + " has sittings 1.." +
                      std::to_string(sittings.size()));
    if (table.participants.empty() || table.participants.back().participant != t->participant)
      table.participants.push_back({t->participant, m->second.group, {}});
    learning::PhaseTrials& phase =
        table.participants.back().phases[learning_phase(sittings[static_cast<std::size_t>(t->block) - 1].phase)];
    phase.trial.push_back(static_cast<double>(phase.trial.size() + 1));
    phase.value.push_back(t->value(Measure::kCompletionTime, 1));
    groups.insert(m->second.group);
  }
  table.groups.assign(groups.begin(), groups.end());
  return table;
}

}  // namespace

std::vector<TaskGroupAnalysis> analyze_group_design(const StudyAnalysis& a) {
  std::vector<TaskGroupAnalysis> out;
  if (!a.group_design || !a.group_design->transfer) return out;
  const protocols::Protocol& p = *a.group_design;
  const std::map<std::string, Member> members = members_of(p);
  transfer::TransferOptions options;
  for (const protocols::Group& g : p.transfer->groups)
    if (!g.training_setting) options.control_group = g.name;
  options.reference_group = p.transfer->groups.front().name;
  for (const protocols::Task& task : p.tasks) {
    TaskGroupAnalysis t;
    t.task = std::string(protocols::task_name(task));
    t.table = table_of(a, t.task, members);
    try {
      t.transfer = transfer::analyze_transfer(t.table, options);
    } catch (const DataError& e) {
      t.transfer_refusal = e.what();
    }
    try {
      t.learning = learning::analyze_learning(t.table, learning::Phase::kTraining, std::nullopt);
    } catch (const DataError& e) {
      t.learning_refusal = e.what();
    }
    out.push_back(std::move(t));
  }
  return out;
}

GroupDesignFiles write_group_design(const std::vector<TaskGroupAnalysis>& tasks, const std::filesystem::path& out,
                                    const std::filesystem::path& gnuplot) {
  GroupDesignFiles files;
  files.markdown = out / "transfer.md";
  files.written.push_back(files.markdown);
  std::ostringstream md;
  md << "# Transfer analysis of a between-group design\n\n"
        "Measure: completion time [s]. A participant's score in a phase is the median of its trials there; groups "
        "are compared on the change from the pre-test (docs/analysis.md, \"Learning curves and transfer designs\"). "
        "The within-participant tables (Friedman, pairwise) do not apply to a between-group design and are not "
        "written. The CUSUM needs a proficiency criterion the protocol does not declare: run `hapticlab stats "
        "learning` on the trials CSV with `--cusum-criterion`.\n";
  for (const TaskGroupAnalysis& t : tasks) {
    md << "\n## " << t.task << "\n\n```\n";
    if (t.transfer) transfer::write_transfer_text(*t.transfer, md);
    else md << "no transfer analysis: " << t.transfer_refusal << "\n";
    md << "```\n";
    const std::filesystem::path trials = out / ("learning_" + t.task + "_trials.csv");
    const std::filesystem::path curves = out / ("learning_" + t.task + "_curves.csv");
    std::ostringstream rows;
    rows << "participant,group,phase,trial,completion_time_s\n";
    for (const learning::ParticipantTrials& p : t.table.participants)
      for (const auto& [phase, v] : p.phases)
        for (std::size_t i = 0; i < v.trial.size(); ++i)
          rows << csv_text(p.participant) << ',' << csv_text(p.group) << ',' << learning::phase_name(phase) << ','
               << v.trial[i] << ',' << format_number(v.value[i]) << '\n';
    write_file_atomically(trials, rows.str());
    std::ostringstream c;
    learning::write_curves_csv(t.learning, c);
    write_file_atomically(curves, c.str());
    if (t.learning_refusal.empty())
      md << "\nLearning curves over the training phase: " << curves.filename().string() << " (trials: "
         << trials.filename().string() << ").\n";
    else
      md << "\nNo learning curves: " << t.learning_refusal << " (trials: " << trials.filename().string() << ").\n";
    files.written.push_back(trials);
    files.written.push_back(curves);
    if (!gnuplot.empty() && !t.learning.participants.empty()) {
      const std::filesystem::path dir = out / "figures" / ("learning_" + t.task);
      for (const std::string& f : learning::write_learning_figures(t.learning, dir, gnuplot))
        files.written.push_back(dir / f);  // the figures' names are relative to their folder
    }
  }
  write_file_atomically(files.markdown, md.str());
  return files;
}

}  // namespace hapticlab::analysis
