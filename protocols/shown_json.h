#pragma once
// A JSON value as a protocol error shows it: its text as it appears in the
// file, cut to 60 characters so one bad field cannot flood the message.
#include <string>

#include <nlohmann/json.hpp>

namespace hapticlab::protocols {

inline std::string shown(const nlohmann::json& v) {
  std::string s = v.dump();
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

}  // namespace hapticlab::protocols
