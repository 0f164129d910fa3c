#pragma once
// The --population option of the commands that simulate participants (sim
// run, session run, demo, plan power, plan calibrate): which population
// they are drawn from. Default: the shipped fitted population
// (examples/population/fitted.json, found like the shipped settings);
// "unfitted": the participant model's defaults without a fit; anything
// else: a population file. A file that is refused (another model version,
// damaged, sources missing; planning/population_file.h) ends the command
// with its reason.
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "core/sim/population.h"
#include "planning/population_file.h"

namespace hapticlab::app {

struct ChosenPopulation {
  PopulationParams point;                     // what a simulated participant is drawn from
  std::optional<planning::PopulationFile> file;  // empty: the unfitted model
  std::string describe;                       // "fitted population examples/... (sha256 0123...)"
  std::string key;  // what a plan records of it: "sha256 <hex>" of the file, or "unfitted model <version>"
};

// Adds --population to `cmd`, storing into `value`.
void add_population_option(CLI::App* cmd, std::string& value);

// Resolves the option's value. Throws planning::PopulationFileError with
// the reason for a refused file; prints a note on stderr when the default
// file cannot be found (the unfitted model is used, and said so).
ChosenPopulation choose_population(const std::string& value);

}  // namespace hapticlab::app
