#pragma once
// What `plan calibrate --fit` writes of a population fit (population_fit.h),
// whatever its outcome: fit_targets.csv (each calibration target beside the
// fitted model's value), fit_parameters.csv (the free parameters' priors
// and posteriors, then the fixed ones), fit_summary.json, and population.json
// only when the fit converged.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "planning/population_fit.h"

namespace hapticlab::planning {

struct FitFiles {
  nlohmann::json summary;                  // fit_summary.json's: the fit's summary, converged, problems, notes
  std::filesystem::path population;        // DIR/population.json (written only when the fit converged)
  std::filesystem::path targets, parameters, summary_file;
  // A fit that did not converge removes an earlier fit's population.json
  // from the folder: beside this fit's diagnostics it would be taken for
  // this fit's (plan power --population DIR/population.json).
  bool removed_earlier_population = false;
};

std::string fit_targets_csv(const PopulationFitResult& r);
std::string fit_parameters_csv(const PopulationFitResult& r);
nlohmann::json fit_summary_json(const PopulationFitResult& r);

// Writes the files into `out` (which must exist); a fit that did not
// converge removes `out`/population.json. Throws std::runtime_error naming
// the file when one cannot be written ("... (disk full?)") or removed.
FitFiles write_fit_files(const PopulationFitResult& r, const std::filesystem::path& out);

}  // namespace hapticlab::planning
