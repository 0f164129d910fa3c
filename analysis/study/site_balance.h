#pragma once
// Sites and settings in a multi-site study (issue 36 §4; docs/analysis.md
// "Multi-site studies"): which site each participant ran at, and whether
// the sites are confounded with the settings.
//
// Per task, n[site][setting] is the number of participants of that site
// with at least one analysed trial of that setting in that task, and
// N[site] the number of participants of that site with any analysed trial
// in that task. With two or more sites in a task:
//   - a setting is CONFOUNDED with a site when it was run at that site only
//     (n[s][x] > 0 at one site, 0 at every other): its difference from the
//     other settings cannot be told from that site's;
//   - the table is BALANCED when every site ran every setting in the same
//     proportion of its participants: n[a][x] * N[b] == n[b][x] * N[a] for
//     every setting x and pair of sites a, b (a complete design is balanced);
//     otherwise UNBALANCED, and the settings whose proportions differ are
//     named: a site effect then leans on those settings' comparisons.
// One site (or a study never merged) has nothing to confound.

#include <map>
#include <string>
#include <vector>

namespace hapticlab::analysis {

struct TrialRecord;  // study_analysis.h

struct SiteBalance {
  std::string task;
  std::vector<std::string> sites;     // sorted
  std::vector<std::string> settings;  // the study's order
  // counts[i][j]: participants of sites[i] with an analysed trial of settings[j].
  std::vector<std::vector<int>> counts;
  std::vector<int> participants;  // per site: with any analysed trial in the task
  // Settings run at one site only (with that site), and settings whose
  // share of participants differs between sites.
  std::vector<std::pair<std::string, std::string>> confounded;  // setting, its only site
  std::vector<std::string> unbalanced;
  bool balanced() const noexcept { return confounded.empty() && unbalanced.empty(); }
  // One sentence: "balanced: ...", "confounded: ...", "unbalanced: ...".
  std::string verdict() const;
};

// `sites`: participant code -> site. Tasks and settings in the given order;
// one SiteBalance per task that has analysed trials at two or more sites.
std::vector<SiteBalance> site_balance(const std::vector<TrialRecord>& trials,
                                      const std::map<std::string, std::string>& sites,
                                      const std::vector<std::string>& tasks, const std::vector<std::string>& settings);

}  // namespace hapticlab::analysis
