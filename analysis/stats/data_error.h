#pragma once
// The exception every analysis function throws when its input data cannot be
// analysed as asked (a malformed CSV, a missing cell, too few blocks). It is a
// std::runtime_error so the command line reports it as `hapticlab: error: ...`.
#include <stdexcept>
#include <string>

namespace hapticlab::analysis {

class DataError : public std::runtime_error {
 public:
  explicit DataError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace hapticlab::analysis
