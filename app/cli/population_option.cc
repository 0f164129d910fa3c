#include "app/cli/population_option.h"

#include <cstdio>
#include <filesystem>

#include "app/cli/data_paths.h"

namespace hapticlab::app {

void add_population_option(CLI::App* cmd, std::string& value) {
  cmd->add_option("--population", value,
                  "Population the simulated participants are drawn from: a population file (docs/simulation.md, "
                  "\"Fitting the population\"), or 'unfitted' for the participant model without a fit (default: the "
                  "shipped fitted population, examples/population/fitted.json)")
      // Given empty (an unset script variable), it would fall back to the
      // default population without a word.
      ->check(CLI::Validator(
          [](std::string& v) {
            return v.empty() ? std::string("'' is refused: name a population file, or 'unfitted'") : std::string();
          },
          "FILE|unfitted"));
}

ChosenPopulation choose_population(const std::string& value) {
  ChosenPopulation c;
  if (value == "unfitted") {
    c.describe = "the unfitted participant model " + std::to_string(kParticipantModelVersion);
    c.key = "unfitted model " + std::to_string(kParticipantModelVersion);
    return c;
  }
  std::filesystem::path path = value;
  if (value.empty()) {
    path = default_population_file();
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
      std::fprintf(stderr,
                   "note: no fitted population at %s; simulating the unfitted participant model %d "
                   "(docs/simulation.md)\n",
                   path.c_str(), kParticipantModelVersion);
      c.describe = "the unfitted participant model " + std::to_string(kParticipantModelVersion) +
                   " (no fitted population found)";
      c.key = "unfitted model " + std::to_string(kParticipantModelVersion);
      return c;
    }
  }
  c.file = planning::read_population_file(path);
  c.point = c.file->point;
  c.describe = "fitted population " + path.string() + " (sha256 " + c.file->sha256.substr(0, 12) + ")";
  c.key = "sha256 " + c.file->sha256;
  return c;
}

}  // namespace hapticlab::app
