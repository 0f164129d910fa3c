// Writes the diagnostics and the population file of a population fit (fit_diagnostics.h).
#include "planning/fit_diagnostics.h"

#include <sstream>
#include <stdexcept>

#include "core/common/csv_format.h"
#include "core/common/output_file.h"
#include "planning/population_file.h"

namespace hapticlab::planning {
namespace {

namespace fs = std::filesystem;

void write_fit_file(const fs::path& path, const std::string& text) {
  try {
    write_file_atomically(path, text);
  } catch (const OutputFileError& e) {
    throw std::runtime_error(std::string(e.what()) + " (disk full?)");
  }
}

}  // namespace

std::string fit_targets_csv(const PopulationFitResult& r) {
  std::ostringstream targets;
  targets << "id,source,where,kind,published_value,published_sd,model_mean,model_low95,model_high95,met,note\n";
  for (const auto& d : r.targets) {
    const bool event = d.target.kind == CalibrationTarget::Kind::kEvent;
    targets << d.target.id << ',' << d.target.source << ',' << csv_text(d.target.where) << ','
            << (event ? "event (probability of the published outcome)" : "value") << ','
            << (event ? "" : format_number(d.target.value)) << ',' << (event ? "" : format_number(d.target.sd))
            << ',' << format_number(d.mean) << ',' << format_number(d.low95) << ',' << format_number(d.high95)
            << ',' << (d.met ? "yes" : "no") << ',' << csv_text(d.note) << '\n';
  }
  return targets.str();
}

std::string fit_parameters_csv(const PopulationFitResult& r) {
  std::ostringstream parameters;
  parameters << "name,free,prior_low,prior_high,prior_scale,posterior_mean,posterior_sd,low95,high95,why,source\n";
  for (const auto& p : r.file.free)
    parameters << p.name << ",yes," << format_number(p.prior_low) << ',' << format_number(p.prior_high) << ','
               << (p.prior_log ? "log" : "linear") << ',' << format_number(p.mean) << ',' << format_number(p.sd)
               << ',' << format_number(p.low95) << ',' << format_number(p.high95) << ',' << csv_text(p.why) << ','
               << csv_text(p.prior_source) << '\n';
  for (const auto& p : r.file.fixed)
    parameters << p.name << ",no,,,," << format_number(p.value) << ",,,,," << csv_text(p.source) << '\n';
  return parameters.str();
}

nlohmann::json fit_summary_json(const PopulationFitResult& r) {
  nlohmann::json summary = r.summary;
  summary["converged"] = r.converged;
  summary["problems"] = r.problems;
  summary["notes"] = r.notes;
  return summary;
}

FitFiles write_fit_files(const PopulationFitResult& r, const fs::path& out) {
  FitFiles f;
  f.targets = out / "fit_targets.csv";
  f.parameters = out / "fit_parameters.csv";
  f.summary_file = out / "fit_summary.json";
  f.population = out / "population.json";
  write_fit_file(f.targets, fit_targets_csv(r));
  write_fit_file(f.parameters, fit_parameters_csv(r));
  f.summary = fit_summary_json(r);
  write_fit_file(f.summary_file, f.summary.dump(2) + "\n");
  if (r.converged) {
    PopulationFile file = r.file;
    write_fit_file(f.population, population_file_text(file));
  } else {
    std::error_code ec;
    f.removed_earlier_population = fs::remove(f.population, ec);
    if (ec)
      throw std::runtime_error("cannot remove " + f.population.string() + ", an earlier fit's population, beside " +
                               "the diagnostics of this fit that did not converge: " + ec.message());
  }
  return f;
}

}  // namespace hapticlab::planning
