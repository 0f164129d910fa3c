#pragma once
// The calibration set: the published findings the simulated population is
// fitted to (issue 35; docs/simulation.md, "Fitting the population"), each
// with the source it comes from and where in the source it stands. Nothing
// outside this set is fitted to: other published effects of degraded
// hardware are kept to check the fitted model's predictions.
//
// Each target is read one of two ways:
// - an event: the source reports an outcome of a study of a given design
//   ("at least 50 % more", "significant", "not significant"). Its
//   likelihood is the probability that a simulated study of the same design
//   and size has that outcome.
// - a value with a spread: the model's value of a quantity (a Hedges' g, a
//   ratio) against the published one, Normal with the stated SD.
#include <string>
#include <vector>

namespace hapticlab::planning {

struct CalibrationSource {
  std::string key;       // "wagner2002"
  std::string citation;  // authors, year, title, venue
  std::string read;      // what of it could be read here, and where (URL)
};

struct CalibrationTarget {
  std::string id;         // "wagner_mean_force"
  std::string source;     // a CalibrationSource key
  std::string where;      // page, table, figure or abstract
  std::string published;  // the finding, in the source's words
  std::string reading;    // how the fit reads it (design, measure, event)
  enum class Kind { kEvent, kValue } kind = Kind::kEvent;
  double value = 0.0;     // kValue: the published value
  double sd = 0.0;        // kValue: its spread (> 0)
  std::string sd_source;  // where the spread comes from
};

const std::vector<CalibrationSource>& calibration_sources();
const std::vector<CalibrationTarget>& calibration_targets();

}  // namespace hapticlab::planning
