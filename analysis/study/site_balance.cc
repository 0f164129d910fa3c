#include "analysis/study/site_balance.h"

#include <algorithm>
#include <cstdint>
#include <set>

#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis {

std::string SiteBalance::verdict() const {
  if (!confounded.empty()) {
    std::string what;
    for (const auto& [setting, site] : confounded)
      what += (what.empty() ? "" : "; ") + ("'" + setting + "' only at site '" + site + "'");
    return "confounded: " + what + " -- the difference of such a setting from the others cannot be told from the "
           "difference of its site from the others";
  }
  if (!unbalanced.empty()) {
    std::string what;
    for (const std::string& s : unbalanced) what += (what.empty() ? "'" : ", '") + s + "'";
    return "unbalanced: the sites ran " + what + " with different shares of their participants, so a difference "
           "between sites weighs on those settings' comparisons";
  }
  return "balanced: every site ran every setting with the same share of its participants";
}

std::vector<SiteBalance> site_balance(const std::vector<TrialRecord>& trials,
                                      const std::map<std::string, std::string>& sites,
                                      const std::vector<std::string>& tasks, const std::vector<std::string>& settings) {
  std::vector<SiteBalance> out;
  for (const std::string& task : tasks) {
    // (site, setting) -> participants; site -> participants.
    std::map<std::pair<std::string, std::string>, std::set<std::string>> who;
    std::map<std::string, std::set<std::string>> at_site;
    for (const TrialRecord& t : trials) {
      if (t.task != task) continue;
      const auto it = sites.find(t.participant);
      if (it == sites.end()) continue;
      who[{it->second, t.setting}].insert(t.participant);
      at_site[it->second].insert(t.participant);
    }
    if (at_site.size() < 2) continue;
    SiteBalance b;
    b.task = task;
    for (const auto& [site, people] : at_site) {
      b.sites.push_back(site);
      b.participants.push_back(static_cast<int>(people.size()));
    }
    for (const std::string& setting : settings) {
      bool any = false;
      for (const std::string& site : b.sites) any = any || who.contains({site, setting});
      if (any) b.settings.push_back(setting);
    }
    b.counts.assign(b.sites.size(), std::vector<int>(b.settings.size(), 0));
    for (std::size_t i = 0; i < b.sites.size(); ++i)
      for (std::size_t j = 0; j < b.settings.size(); ++j)
        if (const auto it = who.find({b.sites[i], b.settings[j]}); it != who.end())
          b.counts[i][j] = static_cast<int>(it->second.size());
    for (std::size_t j = 0; j < b.settings.size(); ++j) {
      std::size_t at = 0, only = 0;
      for (std::size_t i = 0; i < b.sites.size(); ++i)
        if (b.counts[i][j] > 0) {
          ++at;
          only = i;
        }
      if (at == 1) {
        b.confounded.emplace_back(b.settings[j], b.sites[only]);
        continue;
      }
      // Equal shares, compared without division: n_a * N_b == n_b * N_a.
      bool equal = true;
      for (std::size_t a = 0; a < b.sites.size(); ++a)
        for (std::size_t c = a + 1; c < b.sites.size(); ++c)
          equal = equal && std::int64_t{b.counts[a][j]} * b.participants[c] ==
                               std::int64_t{b.counts[c][j]} * b.participants[a];
      if (!equal) b.unbalanced.push_back(b.settings[j]);
    }
    out.push_back(std::move(b));
  }
  return out;
}

}  // namespace hapticlab::analysis
