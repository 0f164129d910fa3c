// Population files (planning/population_file.h): what is written is read
// back as it was, and, through the real binary, a file from another model
// version, a damaged one and one whose cited sources are missing are
// refused with the reason, by the commands that read them.
#include "planning/population_file.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/cli_process.h"
#include "core/common/sha256.h"
#include "testing/fitted_point.h"
#include "testing/test_paths.h"

namespace hapticlab::planning {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using nlohmann::json;

class PopulationFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("hapticlab_population_" + std::string(info->name()) + "_" +
                                        std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  static fs::path shipped() { return fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "population" / "fitted.json"; }
  static json read_json(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return json::parse(s.str());
  }
  // Writes `j` with its sha256 recomputed, so that only what the test
  // changed is wrong with it.
  fs::path write_rehashed(const std::string& name, json j) {
    j.erase("sha256");
    j["sha256"] = sha256_hex(j.dump());
    const fs::path p = dir_ / name;
    std::ofstream(p) << j.dump(2);
    return p;
  }
  // `sim run` with the population: refused before anything is simulated.
  std::pair<int, std::string> sim_run(const fs::path& population) {
    return testing::run_cli(HAPTICLAB_CLI_PATH,
                            "sim run --task clip --max-trial-s 0.2 --settings " +
                                (fs::path(HAPTICLAB_SOURCE_DIR) / "examples/settings/high_fidelity.json").string() +
                                " --population " + population.string() + " --out " + (dir_ / "trial.csv").string());
  }
  fs::path dir_;
};

TEST_F(PopulationFileTest, WhatIsWrittenIsReadBackWithItsChecksum) {
  PopulationFile f;
  f.description = "a test population";
  f.point.visual_gain_mean = 0.55;
  f.point.force_level_log_sd = 0.31;
  for (int k = 0; k < 3; ++k) {
    PopulationParams d = f.point;
    d.consistency_median = 0.1 + 0.01 * k;
    f.draws.push_back(d);
  }
  f.free.push_back({"visual_gain_mean", "why", 0.3, 1.0, false, "a source", 0.55, 0.05, 0.45, 0.65});
  f.fixed.push_back({"visual_gain_sd", 0.1, "an assumption"});
  f.sources = calibration_sources();
  f.targets = calibration_targets();
  f.fit = {{"seed", 7}};
  const std::string text = population_file_text(f);
  std::ofstream(dir_ / "p.json") << text;
  const PopulationFile r = read_population_file(dir_ / "p.json");
  EXPECT_EQ(r.sha256, f.sha256);
  EXPECT_EQ(r.description, "a test population");
  EXPECT_EQ(r.point.visual_gain_mean, 0.55);
  EXPECT_EQ(r.point.force_level_log_sd, 0.31);
  ASSERT_EQ(r.draws.size(), 3u);
  EXPECT_EQ(r.draws[2].consistency_median, f.draws[2].consistency_median);  // to the bit
  ASSERT_EQ(r.free.size(), 1u);
  EXPECT_EQ(r.free[0].prior_source, "a source");
  EXPECT_EQ(r.targets.size(), calibration_targets().size());
  EXPECT_EQ(r.fit["seed"], 7);
}

TEST_F(PopulationFileTest, TheShippedFileIsReadAndCarriesItsUncertaintyAndSources) {
  const PopulationFile f = read_population_file(shipped());
  EXPECT_EQ(f.model_version, kParticipantModelVersion);
  EXPECT_GE(f.draws.size(), 100u);
  EXPECT_EQ(f.free.size(), 4u);
  for (const FreeParameter& p : f.free) {
    EXPECT_FALSE(p.prior_source.empty()) << p.name;
    EXPECT_GT(p.sd, 0.0) << p.name;
  }
  EXPECT_EQ(f.sources.size(), calibration_sources().size());
  EXPECT_TRUE(f.fit.value("converged", false));
}

TEST_F(PopulationFileTest, AnotherModelVersionADamagedFileAndMissingSourcesAreRefusedThroughTheBinary) {
  const json good = read_json(shipped());
  {
    json j = good;
    j["model_version"] = 1;
    const auto [status, out] = sim_run(write_rehashed("old.json", j));
    EXPECT_EQ(status, 1) << out;
    EXPECT_THAT(out, HasSubstr("was fitted for participant model 1, but this hapticlab simulates model 2"));
    EXPECT_THAT(out, HasSubstr("plan calibrate --fit"));
  }
  {
    // Edited after the fit: a parameter changed, the checksum not.
    json j = good;
    j["population"]["visual_gain_mean"] = 0.5;
    const fs::path p = dir_ / "edited.json";
    std::ofstream(p) << j.dump(2);
    const auto [status, out] = sim_run(p);
    EXPECT_EQ(status, 1) << out;
    EXPECT_THAT(out, HasSubstr("is damaged or was edited after the fit"));
  }
  {
    const std::string text = good.dump(2);
    const fs::path p = dir_ / "truncated.json";
    std::ofstream(p) << text.substr(0, text.size() / 2);
    const auto [status, out] = sim_run(p);
    EXPECT_EQ(status, 1) << out;
    EXPECT_THAT(out, HasSubstr("is not valid JSON (damaged?)"));
  }
  {
    json j = good;
    json kept = json::array();
    for (const json& s : j["calibration_set"]["sources"])
      if (s["key"] != "golahmadi2021") kept.push_back(s);
    j["calibration_set"]["sources"] = kept;
    json targets = json::array();
    for (const json& t : j["calibration_set"]["targets"])
      if (t["source"] != "golahmadi2021") targets.push_back(t);
    j["calibration_set"]["targets"] = targets;
    const auto [status, out] = sim_run(write_rehashed("unsourced.json", j));
    EXPECT_EQ(status, 1) << out;
    EXPECT_THAT(out, HasSubstr("cites no source 'golahmadi2021'"));
  }
  {
    json j = good;
    j["calibration_set"]["sources"][0]["citation"] = "";
    const auto [status, out] = sim_run(write_rehashed("uncited.json", j));
    EXPECT_EQ(status, 1) << out;
    EXPECT_THAT(out, HasSubstr("has no citation"));
  }
  {
    // plan power reads the same way, before it simulates anything.
    json j = good;
    j["model_version"] = 3;
    const auto [status, out] = testing::run_cli(
        HAPTICLAB_CLI_PATH, "plan power --studies 1 --no-plots --protocol " +
                                (fs::path(HAPTICLAB_SOURCE_DIR) / "examples/protocols/calibration.json").string() +
                                " --population " + write_rehashed("future.json", j).string() + " --out " +
                                (dir_ / "power").string());
    EXPECT_EQ(status, 1) << out;
    EXPECT_THAT(out, HasSubstr("was fitted for participant model 3"));
    EXPECT_FALSE(fs::exists(dir_ / "power" / "plan_power.db"));
  }
}

}  // namespace
}  // namespace hapticlab::planning

namespace hapticlab::planning {
namespace {

// tests/testing/fitted_point.h writes the shipped fit's point out for core
// tests; a re-fit must carry it along (within the 4 digits written).
TEST(FittedPointTest, TheCoreTestsFittedPointIsTheShippedFits) {
  const PopulationFile shipped =
      read_population_file(std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples/population/fitted.json");
  const PopulationParams written = testing::shipped_fitted_point();
  for (int i = 0; i < PopulationParams::kFields; ++i) {
    const auto [name, value] = shipped.point.field(i);
    EXPECT_NEAR(written.field(i).second, value, 5e-4 * std::abs(value) + 1e-12)
        << name << ": tests/testing/fitted_point.h has " << written.field(i).second << ", fitted.json " << value;
  }
}

}  // namespace
}  // namespace hapticlab::planning
