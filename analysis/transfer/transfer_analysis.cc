#include "analysis/transfer/transfer_analysis.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::transfer {
namespace {

using learning::Phase;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void require_group(const learning::TrialTable& table, const std::string& name, const char* role) {
  if (std::find(table.groups.begin(), table.groups.end(), name) != table.groups.end()) return;
  std::ostringstream m;
  m << "transfer analysis: " << role << " group '" << name << "' has no participants (groups with participants:";
  for (const auto& g : table.groups) m << " " << g;
  m << ")";
  throw DataError(m.str());
}

GroupComparison compare(const std::vector<ParticipantChange>& people, const std::vector<std::string>& groups,
                        const std::string& reference, bool retention, const TransferOptions& options) {
  GroupComparison c;
  c.outcome = retention ? "retention-pre" : "post-pre";
  std::vector<std::vector<double>> values(groups.size());
  for (const auto& p : people) {
    if (retention && !p.retention) {
      c.excluded.push_back(p.participant);
      continue;
    }
    const double change = (retention ? *p.retention : p.post) - p.pre;
    const auto g = static_cast<std::size_t>(std::find(groups.begin(), groups.end(), p.group) - groups.begin());
    values[g].push_back(change);
  }
  c.groups = groups;
  for (const auto& v : values) {
    c.sizes.push_back(v.size());
    c.median_change.push_back(v.empty() ? 0.0 : median(v));
  }
  for (std::size_t g = 0; g < groups.size(); ++g) {
    if (values[g].empty()) {
      c.refusal = "group '" + groups[g] + "' has no participants with a " + (retention ? "retention" : "post") +
                  "-test (allowed: at least 1 per group)";
      return c;
    }
  }
  c.test = group_permutation_test(values, options.permutation);
  const auto r = static_cast<std::size_t>(std::find(groups.begin(), groups.end(), reference) - groups.begin());
  for (std::size_t g = 0; g < groups.size(); ++g) {
    if (g == r) continue;
    c.shifts.push_back({groups[g], hodges_lehmann_shift(values[r], values[g], options.level)});
  }
  return c;
}

// Roscoe's TER per trained group, or the named reason there is none.
void add_transfer_ratios(const learning::TrialTable& table, const TransferOptions& options, TransferAnalysis& out) {
  if (!options.control_group) {
    out.transfer_refusal = "no control group declared (TER needs a group trained on no simulator)";
    return;
  }
  if (!options.criterion) {
    out.transfer_refusal = "no proficiency criterion declared (TER counts post-test trials to criterion)";
    return;
  }
  auto trials_to_criterion = [&](const learning::ParticipantTrials& p) -> std::optional<double> {
    const auto& post = p.phases.at(Phase::kPost);
    for (std::size_t i = 0; i < post.value.size(); ++i) {
      const double v = post.value[i];
      if (options.higher_is_better ? v >= *options.criterion : v <= *options.criterion) return static_cast<double>(i + 1);
    }
    return std::nullopt;
  };
  auto training_trials = [](const learning::ParticipantTrials& p) {
    auto it = p.phases.find(Phase::kTraining);
    return it == p.phases.end() ? 0.0 : static_cast<double>(it->second.trial.size());
  };
  std::vector<double> control_y;
  std::string control_missing;
  for (const auto& p : table.participants) {
    if (p.group != *options.control_group) continue;
    if (training_trials(p) > 0.0) {
      std::ostringstream m;
      m << "transfer analysis: control group '" << p.group << "' participant " << p.participant << " has "
        << training_trials(p) << " training trials (allowed: 0; the TER's control trains on no simulator)";
      throw DataError(m.str());
    }
    if (auto y = trials_to_criterion(p)) control_y.push_back(*y);
    else control_missing += (control_missing.empty() ? "" : " ") + p.participant;
  }
  for (const auto& g : table.groups) {
    if (g == *options.control_group) continue;
    GroupTransfer t;
    t.group = g;
    std::vector<double> y, x;
    std::string missing;
    for (const auto& p : table.participants) {
      if (p.group != g) continue;
      if (auto v = trials_to_criterion(p)) y.push_back(*v);
      else missing += (missing.empty() ? "" : " ") + p.participant;
      x.push_back(training_trials(p));
    }
    if (!control_missing.empty() || !missing.empty()) {
      std::string who;
      if (!control_missing.empty()) who += control_missing + " (" + *options.control_group + ")";
      if (!missing.empty()) who += (who.empty() ? "" : " ") + missing + " (" + g + ")";
      t.refusal = "criterion not reached in the post-test by: " + who + " (trials to criterion unknown; not guessed)";
    } else {
      try {
        t.ratio = transfer_effectiveness_ratio(control_y, y, x);
      } catch (const DataError& e) {
        t.refusal = e.what();
      }
    }
    out.transfer.push_back(t);
  }
}

}  // namespace

TransferAnalysis analyze_transfer(const learning::TrialTable& table, const TransferOptions& options) {
  TransferAnalysis out;
  out.measure = table.measure;
  if (table.groups.size() < 2) {
    std::ostringstream m;
    m << "transfer analysis: " << table.groups.size() << " group(s) with participants (allowed: at least 2)";
    throw DataError(m.str());
  }
  if (options.control_group) require_group(table, *options.control_group, "control");
  if (options.reference_group) require_group(table, *options.reference_group, "reference");
  out.reference = options.reference_group ? *options.reference_group
                  : options.control_group ? *options.control_group
                                          : table.groups.front();
  bool any_retention = false;
  for (const auto& p : table.participants) {
    ParticipantChange c{p.participant, p.group, 0.0, 0.0, std::nullopt};
    for (Phase phase : {Phase::kPre, Phase::kPost}) {
      auto it = p.phases.find(phase);
      if (it == p.phases.end()) {
        throw DataError("transfer analysis: participant " + p.participant + " has no " + learning::phase_name(phase) +
                        "-test trial (allowed: every participant has pre- and post-test trials)");
      }
      (phase == Phase::kPre ? c.pre : c.post) = median(it->second.value);
    }
    if (auto it = p.phases.find(Phase::kRetention); it != p.phases.end()) {
      c.retention = median(it->second.value);
      any_retention = true;
    }
    out.participants.push_back(c);
  }
  out.comparisons.push_back(compare(out.participants, table.groups, out.reference, false, options));
  if (any_retention) out.comparisons.push_back(compare(out.participants, table.groups, out.reference, true, options));

  add_transfer_ratios(table, options, out);
  return out;
}

void write_transfer_text(const TransferAnalysis& a, std::ostream& out) {
  out << std::setprecision(4);
  out << "Transfer analysis of " << a.measure << " (participant score: median of its trials in a phase; "
      << "shifts relative to group '" << a.reference << "')\n";
  for (const auto& c : a.comparisons) {
    out << "\n" << c.outcome << ":\n";
    for (std::size_t g = 0; g < c.groups.size(); ++g)
      out << "  " << c.groups[g] << ": n = " << c.sizes[g] << ", median change = " << c.median_change[g] << "\n";
    if (!c.excluded.empty()) {
      out << "  excluded (no such phase):";
      for (const auto& e : c.excluded) out << " " << e;
      out << "\n";
    }
    if (!c.test) {
      out << "  refused: " << c.refusal << "\n";
      continue;
    }
    const auto& t = *c.test;
    out << "  rank permutation test (Kruskal-Wallis H = " << t.h << "): p = " << t.p_value;
    if (t.exact) out << " (exact, " << static_cast<unsigned long long>(std::llround(t.assignments)) << " assignments)\n";
    else out << " (Monte Carlo, " << t.evaluated << " draws of " << t.assignments << " assignments; 95 % interval of p ["
             << t.p_interval.low << ", " << t.p_interval.high << "])\n";
    for (const auto& s : c.shifts) {
      out << "  Hodges-Lehmann shift " << s.group << " - " << a.reference << " = " << s.shift.shift;
      if (s.shift.has_interval) out << ", " << s.shift.achieved_level * 100 << " % interval [" << s.shift.low << ", " << s.shift.high << "]\n";
      else out << " (no interval: " << s.shift.no_interval_reason << ")\n";
    }
  }
  out << "\nTransfer effectiveness ratio (Roscoe): ";
  if (!a.transfer_refusal.empty()) {
    out << "refused: " << a.transfer_refusal << "\n";
    return;
  }
  out << "\n";
  for (const auto& t : a.transfer) {
    out << "  " << t.group << ": ";
    if (t.ratio) out << "TER = " << t.ratio->ter << " (Yc = " << t.ratio->control_trials_to_criterion << ", Yx = "
                     << t.ratio->experimental_trials_to_criterion << ", X = " << t.ratio->training_trials << " trials)\n";
    else out << "refused: " << t.refusal << "\n";
  }
}

}  // namespace hapticlab::analysis::transfer
