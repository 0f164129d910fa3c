// What plan calibrate --fit writes of a fit (planning/fit_diagnostics.h),
// without the CLI and without fitting: the targets' and parameters' tables
// of a result set by hand, and no population.json for a fit that did not
// converge.
#include "planning/fit_diagnostics.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace hapticlab::planning {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

PopulationFitResult fit_result() {
  PopulationFitResult r;
  TargetDiagnostic event;
  event.target.id = "wagner_event";
  event.target.source = "wagner2002";
  event.target.where = "Table 1, p. 3";
  event.target.kind = CalibrationTarget::Kind::kEvent;
  event.mean = 0.5;
  event.low95 = 0.25;
  event.high95 = 0.75;
  event.met = true;
  TargetDiagnostic value;
  value.target.id = "mean_force";
  value.target.source = "thesis";
  value.target.where = "3.4";
  value.target.kind = CalibrationTarget::Kind::kValue;
  value.target.value = 1.5;
  value.target.sd = 0.25;
  value.mean = 2.5;
  value.low95 = 2;
  value.high95 = 3;
  value.met = false;
  value.note = "missed by 1";
  r.targets = {event, value};
  FreeParameter f;
  f.name = "visual_gain_mean";
  f.why = "unknown";
  f.prior_low = 0.1;
  f.prior_high = 1;
  f.prior_log = true;
  f.prior_source = "guess";
  f.mean = 0.5;
  f.sd = 0.125;
  f.low95 = 0.25;
  f.high95 = 0.75;
  r.file.free = {f};
  r.file.fixed = {{"hand_mass_kg", 0.5, "anthropometry"}};
  r.converged = false;
  r.problems = {"ESS 3 < 100"};
  r.summary = {{"seconds", 12.0}};
  return r;
}

TEST(FitDiagnosticsTest, TheTablesOfTheTargetsAndParameters) {
  const PopulationFitResult r = fit_result();
  EXPECT_EQ(fit_targets_csv(r),
            "id,source,where,kind,published_value,published_sd,model_mean,model_low95,model_high95,met,note\n"
            "wagner_event,wagner2002,\"Table 1, p. 3\",event (probability of the published outcome),,,0.5,0.25,0.75,"
            "yes,\n"
            "mean_force,thesis,3.4,value,1.5,0.25,2.5,2,3,no,missed by 1\n");
  EXPECT_EQ(fit_parameters_csv(r),
            "name,free,prior_low,prior_high,prior_scale,posterior_mean,posterior_sd,low95,high95,why,source\n"
            "visual_gain_mean,yes,0.1,1,log,0.5,0.125,0.25,0.75,unknown,guess\n"
            "hand_mass_kg,no,,,,0.5,,,,,anthropometry\n");
  const nlohmann::json summary = fit_summary_json(r);
  EXPECT_EQ(summary.at("seconds"), 12.0);
  EXPECT_EQ(summary.at("converged"), false);
  EXPECT_EQ(summary.at("problems"), nlohmann::json::array({"ESS 3 < 100"}));
}

TEST(FitDiagnosticsTest, AFitThatDidNotConvergeWritesItsDiagnosticsButNoPopulation) {
  const fs::path dir = fs::temp_directory_path() / ("hapticlab_fit_diagnostics_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const PopulationFitResult r = fit_result();
  // An earlier fit's population in the same folder goes: beside this fit's
  // diagnostics it would be taken for this fit's.
  std::ofstream(dir / "population.json") << "{}\n";
  const FitFiles files = write_fit_files(r, dir);
  EXPECT_EQ(files.population, dir / "population.json");
  EXPECT_FALSE(fs::exists(files.population));
  EXPECT_TRUE(files.removed_earlier_population);
  EXPECT_FALSE(write_fit_files(r, dir).removed_earlier_population);
  std::ifstream in(dir / "fit_targets.csv");
  std::ostringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), fit_targets_csv(r));
  EXPECT_TRUE(fs::exists(dir / "fit_parameters.csv"));
  std::ifstream summary(dir / "fit_summary.json");
  EXPECT_EQ(nlohmann::json::parse(summary), files.summary);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hapticlab::planning
