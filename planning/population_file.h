#pragma once
// A fitted population as a file: versioned, cited and checksummed JSON
// (examples/population/fitted.json is the shipped one; docs/simulation.md,
// "Fitting the population"). `hapticlab plan calibrate --fit` writes it;
// `plan power`, `sim run`, `session run` and `demo` read it.
//
// It holds the participant model version it was fitted for, the point
// estimate (the posterior mean), posterior draws (plan power samples a
// study's population from them), every free parameter with its prior, where
// the prior comes from and its posterior summary, the fixed parameters, the
// calibration set with its sources, how the fit was made (method, seed,
// software) and a SHA-256 of all of that. A file from another model
// version, a damaged or edited one, or one whose cited sources are missing
// is refused with the reason (PopulationFileError), never reinterpreted.
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/sim/population.h"
#include "planning/calibration_set.h"

namespace hapticlab::planning {

class PopulationFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr const char* kPopulationFormat = "hapticlab-population";
inline constexpr int kPopulationFormatVersion = 1;

struct FreeParameter {
  std::string name;   // a PopulationParams field
  std::string why;    // why it is free
  double prior_low = 0.0, prior_high = 0.0;
  bool prior_log = false;    // uniform in log(value) rather than value
  std::string prior_source;  // where the bounds come from
  double mean = 0.0, sd = 0.0, low95 = 0.0, high95 = 0.0;  // posterior
};

struct FixedParameter {
  std::string name;    // a PopulationParams field
  double value = 0.0;
  std::string source;  // why this value
};

struct PopulationFile {
  int model_version = kParticipantModelVersion;
  std::string description;
  PopulationParams point;                // posterior mean: the population without model uncertainty
  std::vector<PopulationParams> draws;   // posterior draws, >= 1
  std::vector<FreeParameter> free;
  std::vector<FixedParameter> fixed;
  std::vector<CalibrationSource> sources;
  std::vector<CalibrationTarget> targets;
  nlohmann::json fit;                    // method, command, seed, software, convergence, diagnostics summary
  std::string sha256;                    // of the file's contents without this field (set by read and text)
};

// The file's text (JSON, 2-space indent) with its sha256 field computed.
std::string population_file_text(PopulationFile& file);

// Reads and checks `path`. Throws PopulationFileError naming the file and
// what is wrong: unreadable, not JSON, another format or format version,
// another participant model version, a checksum that does not match the
// contents, a missing or invalid field, a population outside its valid
// ranges, a calibration source without citation, a target citing a source
// the file does not have, or a source of the calibration set missing.
PopulationFile read_population_file(const std::filesystem::path& path);

}  // namespace hapticlab::planning
