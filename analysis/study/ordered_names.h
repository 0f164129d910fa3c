#pragma once
// The study's names (settings, participants, tasks) are kept in order of
// first appearance; this appends a name the list does not hold yet.
#include <algorithm>
#include <string>
#include <vector>

namespace hapticlab::analysis {

inline void add_unique(std::vector<std::string>& list, const std::string& value) {
  if (std::find(list.begin(), list.end(), value) == list.end()) list.push_back(value);
}

}  // namespace hapticlab::analysis
