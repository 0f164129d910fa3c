#include "protocols/group_assignment.h"

#include <stdexcept>

#include "protocols/protocol_error.h"
#include "protocols/rng.h"

namespace hapticlab::protocols {

std::vector<std::size_t> assign_groups(const Protocol& p, const std::string& source) {
  if (!p.transfer) throw std::invalid_argument("assign_groups(): the protocol has no groups");
  const TransferDesign& d = *p.transfer;
  const std::size_t n_groups = d.groups.size();

  // Strata in order of first appearance.
  std::vector<std::string> strata;
  std::vector<std::size_t> stratum_of(p.participants.size(), 0);
  for (std::size_t i = 0; i < p.participants.size(); ++i) {
    std::string value;
    if (!d.stratify_by.empty()) {
      const auto it = p.participants[i].attributes.find(d.stratify_by);
      if (it == p.participants[i].attributes.end())
        throw std::invalid_argument("assign_groups(): participant " + p.participants[i].code + " lacks " + d.stratify_by);
      value = it->second;
    }
    std::size_t s = 0;
    while (s < strata.size() && strata[s] != value) ++s;
    if (s == strata.size()) strata.push_back(value);
    stratum_of[i] = s;
  }

  std::vector<int> room(n_groups, -1);  // -1: no declared size
  for (std::size_t g = 0; g < n_groups; ++g)
    if (d.groups[g].size) room[g] = *d.groups[g].size;

  Rng rng = Rng::for_stream(p.seed, "groups");
  std::vector<std::size_t> group_of(p.participants.size(), 0);
  for (std::size_t s = 0; s < strata.size(); ++s) {
    std::vector<std::size_t> block;  // the rest of the current block, dealt from the back
    for (std::size_t i = 0; i < p.participants.size(); ++i) {
      if (stratum_of[i] != s) continue;
      while (!block.empty() && room[block.back()] == 0) block.pop_back();
      if (block.empty()) {
        for (std::size_t g = 0; g < n_groups; ++g)
          if (room[g] != 0) block.push_back(g);
        // Declared sizes sum to the participant count (transfer_rules.h).
        if (block.empty()) throw std::logic_error("assign_groups(): no group has room left");
        shuffle(block, rng);
      }
      group_of[i] = block.back();
      block.pop_back();
      if (room[group_of[i]] > 0) --room[group_of[i]];
    }
  }

  std::vector<int> count(n_groups, 0);
  for (std::size_t g : group_of) ++count[g];
  for (std::size_t g = 0; g < n_groups; ++g)
    if (count[g] == 0)
      throw ProtocolError(source, index_path("groups", g),
                          "(\"" + d.groups[g].name + "\") has no participants after randomization: " +
                              std::to_string(p.participants.size()) + " participant(s) for " + std::to_string(n_groups) +
                              " groups" + (strata.size() > 1 ? " in " + std::to_string(strata.size()) + " strata" : "") +
                              "; every group needs at least one");
  return group_of;
}

}  // namespace hapticlab::protocols
