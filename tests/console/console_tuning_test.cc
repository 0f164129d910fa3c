// The Tuning page's free trial (console/console_tuning.h) without the
// browser: a change reaches the running loop, a value out of the documented
// range changes nothing, and a saved file is one `settings check` accepts.
#include "console/console_tuning.h"
#include "console/console_conflict.h"

#include <unistd.h>

#include <array>
#include <chrono>
#include <map>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "testing/files.h"
#include "testing/test_paths.h"

namespace hapticlab::console {
namespace {

using ::testing::HasSubstr;

class ConsoleTuningTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("console_tuning_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    config_.out_dir = dir_;
    // The virtual clock runs the free trial as fast as it can: seconds of
    // loop time per wall second, the same physics.
    config_.clock = ClockKind::kVirtual;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  static NamedSettings high_fidelity() { return settings_from_json_text(R"({"name": "High Fidelity"})", "test"); }

  std::filesystem::path dir_;
  ConsoleTuningConfig config_;
  DeviceHealth device_;
};

// Force feedback switched off by the sliders while the loop runs ("No Force
// Feedback" is tip_force_saturation at 0 N): from one update on, every
// displayed force is 0 while the tissue still pushes on the tip, within the
// same repetition of the task (the change did not wait for a new trial).
TEST_F(ConsoleTuningTest, AChangeReachesTheRunningLoopBetweenTwoUpdates) {
  ConsoleTuning tuning(config_, device_);
  tuning.start("dissection", high_fidelity());
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  auto max_force = [](const LivePoint& a, const LivePoint& b, bool displayed) {
    return std::max(displayed ? a.displayed_force_N : a.tip_force_N, displayed ? b.displayed_force_N : b.tip_force_N);
  };
  // Both instruments' points, merged by time; only those of one repetition.
  std::vector<std::pair<LivePoint, LivePoint>> points;
  int repetition = -1;
  double last_t = -1.0;
  auto collect = [&] {
    const int now = tuning.status()["free_trial"].get<int>();
    if (now != repetition) {
      repetition = now;
      points.clear();
      last_t = -1.0;
    }
    const auto fresh = tuning.live_since(last_t);
    for (std::size_t i = 0; i < std::min(fresh[0].size(), fresh[1].size()); ++i) {
      points.emplace_back(fresh[0][i], fresh[1][i]);
      last_t = fresh[0][i].t_s;
    }
  };
  // On the virtual clock a repetition can end between the change and the
  // loop taking it (or within the 2 s after): then feedback is switched back
  // on and the change is made again in a later repetition.
  tuning.set("tip_force_saturation.limit_N", 0.0);  // no effect while saturation is off
  int changed_in = -1;
  double applied_t_s = -1.0;
  int attempts = 0;
  for (; attempts < 5 && std::chrono::steady_clock::now() < deadline; ++attempts) {
    if (attempts > 0) tuning.set("tip_force_saturation.enabled", false);
    const int after = repetition;
    int pushing = 0;
    while ((pushing < 20 || repetition == after) && std::chrono::steady_clock::now() < deadline) {
      collect();
      pushing = 0;
      for (const auto& [l, r] : points) pushing += max_force(l, r, true) > 0.1f;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    ASSERT_GE(pushing, 20) << "no contact with force feedback within 60 s";
    changed_in = repetition;
    tuning.set("tip_force_saturation.enabled", true);
    // When the loop had the change: not the newest point drained at set()
    // (on the virtual clock the loop may run far ahead of the drain), but the
    // loop time the console read after handing it over.
    applied_t_s = -1.0;
    while (applied_t_s < 0.0 && std::chrono::steady_clock::now() < deadline) {
      const nlohmann::json status = tuning.status();
      if (status["free_trial"] != changed_in) break;
      if (status.contains("applied_t_s")) applied_t_s = status["applied_t_s"];
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    // Collect until 2 s of loop time after the change have passed in the same repetition.
    while (repetition == changed_in && applied_t_s >= 0.0 &&
           (points.empty() || points.back().first.t_s < applied_t_s + 2.0) &&
           std::chrono::steady_clock::now() < deadline) {
      collect();
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    if (repetition == changed_in && applied_t_s >= 0.0 && !points.empty() &&
        points.back().first.t_s >= applied_t_s + 2.0)
      break;
  }
  tuning.stop();
  // The loop's thread logs its "stop" as it ends: waited for, so the log
  // read below is whole (read at once, it held the stop or not by a race).
  tuning.wait_until_ended();
  ASSERT_LT(attempts, 5) << "in 5 repetitions the task ended within 2 s of the change every time";
  ASSERT_EQ(repetition, changed_in);
  ASSERT_GE(applied_t_s, 0.0);
  ASSERT_GE(points.back().first.t_s, applied_t_s + 2.0);
  std::size_t last_felt = 0;  // index of the last point with any displayed force
  for (std::size_t i = 0; i < points.size(); ++i)
    if (max_force(points[i].first, points[i].second, true) > 1e-6f) last_felt = i;
  std::size_t pushed_unfelt = 0;
  for (std::size_t i = last_felt + 1; i < points.size(); ++i)
    pushed_unfelt += max_force(points[i].first, points[i].second, false) > 0.05f;
  EXPECT_GT(points[last_felt].first.t_s, 0.0);
  // The engine takes a change at the start of its next update, or of the one
  // after if that update had begun when the console read the loop time: no
  // force is displayed later than 2 updates (1 kHz) after applied_t_s.
  EXPECT_LE(points[last_felt].first.t_s, applied_t_s + 2.0 / config_.rate_Hz + 1e-9) << "force displayed after the change";
  EXPECT_GE(pushed_unfelt, 10u) << "no contact after the change: the test shows nothing";

  // Both changes are in the log, with the repetition they were made in,
  // then the stop.
  const nlohmann::json log = tuning.status()["log"];
  ASSERT_GE(log.size(), 4u);
  EXPECT_EQ(log[1]["field"], "tip_force_saturation.limit_N");
  EXPECT_EQ(log[1]["to"], "0.0");
  EXPECT_EQ(log.back()["field"], "stop");
  const nlohmann::json& changed = log[log.size() - 2];
  EXPECT_EQ(changed["field"], "tip_force_saturation.enabled");
  EXPECT_EQ(changed["to"], "true");
  EXPECT_EQ(changed["free_trial"], changed_in);
  const std::string csv = testing::slurp(dir_ / "tuning-log.csv");
  EXPECT_THAT(csv, HasSubstr("utc,free_trial,loop_t_s,field,from,to\n"));
  EXPECT_THAT(csv, HasSubstr(",\"tip_force_saturation.enabled\",\"false\",\"true\"\n"));
}

// The loader's own checks, field by field: a refused value names the field,
// the value and the range, and leaves the settings as they were.
TEST_F(ConsoleTuningTest, OutOfRangeOrMistypedChangesAreRefusedAndChangeNothing) {
  ConsoleTuning tuning(config_, device_);
  const nlohmann::json before = tuning.status()["settings"];
  EXPECT_THAT([&] { tuning.set("translation.friction.dynamic_level_N", 60.0); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  HasSubstr("'translation.friction.dynamic_level_N' is 60, but must be >= 0 and <= 50")));
  EXPECT_THAT([&] { tuning.set("translation.backlash.gap_m", 0.0); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("must be > 0")));
  EXPECT_THAT([&] { tuning.set("translation.friction.level", 0.1); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("is not a settings field")));
  EXPECT_THAT([&] { tuning.set("translation.friction", 0.1); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("is not a settings field")));
  EXPECT_THAT([&] { tuning.set("translation.friction.enabled", 1); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("is not true or false")));
  EXPECT_THAT([&] { tuning.set("translation.friction.dynamic_level_N", "0.2"); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("is not a number")));
  EXPECT_EQ(tuning.status()["settings"], before);
  EXPECT_TRUE(tuning.status()["log"].empty());
}

// A change the tuning log cannot record is not made: the answer says why
// (the console answers 500 with it), the settings and the log stay as they
// were. tuning-log.csv is a folder here, which no one can append to.
TEST_F(ConsoleTuningTest, AChangeTheLogCannotRecordIsNotMade) {
  ConsoleTuning tuning(config_, device_);
  tuning.start("clip", high_fidelity());
  std::filesystem::remove(dir_ / "tuning-log.csv");
  std::filesystem::create_directories(dir_ / "tuning-log.csv");
  const nlohmann::json before = tuning.status()["settings"];
  const std::size_t logged = tuning.status()["log"].size();  // "start"
  EXPECT_THAT([&] { tuning.set("translation.friction.enabled", true); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  HasSubstr("the change of 'translation.friction.enabled' was not made: cannot append to")));
  EXPECT_EQ(tuning.status()["settings"], before);
  EXPECT_EQ(tuning.status()["log"].size(), logged);
  // Nothing is missing from the log: the change was not made.
  EXPECT_EQ(tuning.status()["error"], "");
  // Once it can be written again, the same change is made and logged.
  std::filesystem::remove(dir_ / "tuning-log.csv");
  tuning.set("translation.friction.enabled", true);
  EXPECT_EQ(tuning.status()["log"].back()["field"], "translation.friction.enabled");
  EXPECT_NE(tuning.status()["settings"], before);
  tuning.stop();
  tuning.wait_until_ended();
}

// A change with no free trial running was answered as made and logged
// under the last repetition at loop time 0: before Start it was then
// replaced by the setting Start loads, after the end no loop ran with it.
// Refused (the console answers 409), nothing logged or changed.
TEST_F(ConsoleTuningTest, AChangeWithoutARunningFreeTrialIsRefused) {
  ConsoleTuning tuning(config_, device_);
  EXPECT_THAT([&] { tuning.set("translation.friction.dynamic_level_N", 0.3); },
              ::testing::ThrowsMessage<ConsoleConflict>(HasSubstr("no free trial is running")));
  EXPECT_TRUE(tuning.status()["log"].empty());
  tuning.start("clip", high_fidelity());
  tuning.set("translation.friction.dynamic_level_N", 0.3);
  tuning.stop();
  tuning.wait_until_ended();
  const nlohmann::json settings = tuning.status()["settings"];
  const std::size_t logged = tuning.status()["log"].size();
  EXPECT_THAT([&] { tuning.set("translation.friction.dynamic_level_N", 0.9); },
              ::testing::ThrowsMessage<ConsoleConflict>(HasSubstr("no free trial is running")));
  EXPECT_EQ(tuning.status()["settings"], settings);
  EXPECT_EQ(tuning.status()["log"].size(), logged);
  // Save keeps what the free trial ran with.
  const NamedSettings back = load_settings_file(dir_ / tuning.save("Pilot 0.3"));
  EXPECT_DOUBLE_EQ(back.engine.translation.friction.dynamic_level, 0.3);
}

// The page's sliders come from the loader's table: every field of
// docs/settings.md, with the same range.
TEST_F(ConsoleTuningTest, ReferenceListsEveryFieldWithTheLoadersRange) {
  const nlohmann::json fields = ConsoleTuning::reference()["fields"];
  ASSERT_EQ(fields.size(), settings_field_reference().size());
  bool found = false;
  for (const auto& f : fields)
    if (f["path"] == "translation.inertia.mass_kg") {
      found = true;
      EXPECT_EQ(f["min"], 0.001);
      EXPECT_EQ(f["max"], 10.0);
      EXPECT_EQ(f["min_exclusive"], false);
    }
  EXPECT_TRUE(found);
  const std::string md = settings_reference_markdown();
  for (const auto& f : fields) EXPECT_THAT(md, HasSubstr("`" + f["path"].get<std::string>() + "`"));
}

TEST_F(ConsoleTuningTest, SavedSettingsPassSettingsCheckAndAreNotOverwritten) {
  ConsoleTuning tuning(config_, device_);
  tuning.start("clip", high_fidelity());
  tuning.set("translation.friction.enabled", true);
  tuning.set("translation.friction.dynamic_level_N", 0.3);
  tuning.stop();
  tuning.wait_until_ended();
  const std::string file = tuning.save("Pilot friction + 0.3");
  EXPECT_EQ(file, "pilot_friction_-_0_3.json");
  const auto [status, out] = testing::run_cli(kBinary, "settings check " + (dir_ / file).string());
  EXPECT_EQ(status, 0) << out;
  const NamedSettings back = load_settings_file(dir_ / file);
  EXPECT_EQ(back.name, "Pilot friction + 0.3");
  EXPECT_TRUE(back.engine.translation.friction.enabled);
  EXPECT_DOUBLE_EQ(back.engine.translation.friction.dynamic_level, 0.3);
  EXPECT_THAT([&] { tuning.save("Pilot friction + 0.3"); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("exists; choose another name")));
  EXPECT_THAT([&] { tuning.save("../escape"); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("may hold")));
  EXPECT_EQ(tuning.file(file), std::filesystem::weakly_canonical(dir_ / file));
  EXPECT_EQ(tuning.file("../" + file), std::nullopt);
}

// A device preset tuned on the page is no longer the device its source
// describes (issue 35): the change is taken, and the settings drop the
// source, where the preset's own checks (every number from the source)
// would refuse it.
TEST_F(ConsoleTuningTest, ATunedDevicePresetDropsItsSource) {
  ConsoleTuning tuning(config_, device_);
  tuning.start("clip", load_settings_file(std::filesystem::path(HAPTICLAB_SOURCE_DIR) /
                                          "examples/settings/devices/novint_falcon.json"));
  EXPECT_TRUE(tuning.status()["settings"].contains("source"));
  EXPECT_NO_THROW(tuning.set("translation.friction.dynamic_level_N", 1.0));  // the source says 3.6
  tuning.stop();
  EXPECT_FALSE(tuning.status()["settings"].contains("source"));
  const NamedSettings back = load_settings_file(dir_ / tuning.save("Falcon with less friction"));
  EXPECT_FALSE(back.source.has_value());
  EXPECT_DOUBLE_EQ(back.engine.translation.friction.dynamic_level, 1.0);
}

// The free trial's pilot participant is drawn from the configured
// population (the console passes the sessions' one): in the first 3 s of
// loop time of the first repetition, the instrument is where it was at the
// same loop time under the same population, and elsewhere under another.
// (Compared at equal loop times: on the virtual clock the loop can run
// ahead of the live view's drain, which then skips samples.)
TEST_F(ConsoleTuningTest, ThePilotParticipantComesFromTheConfiguredPopulation) {
  using Pose = std::array<float, 3>;
  const auto first_seconds = [this](const PopulationParams& population) {
    ConsoleTuningConfig config = config_;
    config.population = population;
    // One repetition of 3.5 s of loop time and no second one, whose start
    // would clear the live view: on the virtual clock a repetition can end
    // within milliseconds, and a test thread held off that long (a busy CI
    // machine) found the first one's points gone (last_t -1).
    config.max_s = 3.5;
    ConsoleTuning tuning(config, device_);
    tuning.start("clip", high_fidelity());
    std::map<double, Pose> pose;  // the left instrument's, by loop time
    double last_t = -1.0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (last_t < 3.0 && tuning.status()["free_trial"] <= 1 && std::chrono::steady_clock::now() < deadline) {
      const auto fresh = tuning.live_since(last_t);  // (a range-for over [0] of the temporary would dangle)
      for (const LivePoint& p : fresh[0]) {
        if (p.t_s <= 3.0) pose[p.t_s] = {p.insertion_m, p.pitch_rad, p.yaw_rad};
        last_t = p.t_s;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    tuning.stop();
    EXPECT_GE(last_t, 3.0) << "the first repetition ended, or the loop stalled, before 3 s of loop time";
    return pose;
  };
  // {points at the same loop time, of which at another pose}
  const auto compare = [](const std::map<double, Pose>& a, const std::map<double, Pose>& b) {
    std::pair<int, int> n{0, 0};
    for (const auto& [t_s, pose] : a)
      if (const auto it = b.find(t_s); it != b.end()) {
        ++n.first;
        n.second += it->second != pose;
      }
    return n;
  };
  PopulationParams other;
  other.consistency_median = 0.1;
  other.visual_gain_mean = 0.9;
  const auto a = first_seconds(other);
  const auto [common, moved] = compare(a, first_seconds(other));
  EXPECT_GE(common, 100) << "too few points at equal loop times to compare";
  EXPECT_EQ(moved, 0) << "the same population, another motion";
  const auto [common_default, moved_default] = compare(a, first_seconds(PopulationParams{}));
  EXPECT_GE(common_default, 100);
  EXPECT_GT(moved_default, common_default / 2) << "another population, the same motion: it did not reach the trial";
}

}  // namespace
}  // namespace hapticlab::console
