#pragma once
// The outcome of a rank test with a chi-square reference distribution.
#include <cstddef>
#include <string>

namespace hapticlab::analysis {

struct TestResult {
  std::string method;          // e.g. "Friedman", "Durbin", "Skillings-Mack"
  double statistic = 0.0;      // chi-square statistic, >= 0
  double df = 0.0;             // degrees of freedom (treatments − 1)
  double p = 1.0;              // upper-tail chi-square p-value, in [0, 1]
  std::size_t blocks = 0;      // blocks that entered the statistic
  std::size_t treatments = 0;  // treatments compared
  std::size_t observations = 0;
};

}  // namespace hapticlab::analysis
