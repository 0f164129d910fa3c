// The shipped protocol files load and produce the schedules the thesis
// describes.
#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/settings/settings_json.h"
#include "protocols/design.h"
#include "protocols/protocol_json.h"
#include "protocols/schedule.h"

namespace hapticlab::protocols {
namespace {

const std::filesystem::path kDir = std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples" / "protocols";

int count_task(const ParticipantPlan& pp, Task task) {
  return static_cast<int>(
      std::count_if(pp.trials.begin(), pp.trials.end(), [&](const PlannedTrial& t) { return t.task == task; }));
}

std::set<std::string> names_of(const ParticipantPlan& pp) {
  std::set<std::string> out;
  for (const auto& s : pp.settings) out.insert(s.name);
  return out;
}

TEST(ProtocolExamplesTest, ThesisAsRunMatchesTable33) {
  const Protocol p = load_protocol_file(kDir / "thesis_as_run.json");
  EXPECT_EQ(p.settings.size(), 8u);
  const StudyPlan plan = make_study_plan(p);
  ASSERT_EQ(plan.participants.size(), 3u);
  const auto& s1 = plan.participants[0];
  const auto& s2 = plan.participants[1];
  const auto& s3 = plan.participants[2];
  EXPECT_EQ(s1.code, "S1");
  const std::set<std::string> core{"High Fidelity", "No Force Feedback", "All Degradations"};
  auto with = [&](std::initializer_list<const char*> extra) {
    std::set<std::string> s = core;
    for (const char* e : extra) s.insert(e);
    return s;
  };
  EXPECT_EQ(names_of(s1), with({"Cogging", "Inertia"}));
  EXPECT_EQ(names_of(s2), with({"Cogging", "Friction"}));
  EXPECT_EQ(names_of(s3), with({"Inertia + Backlash", "Force Saturation"}));

  // 5 settings × (3 dissection + 9 clip) = 60; Surgeon 3 dissection only: 15.
  EXPECT_EQ(s1.trials.size(), 60u);
  EXPECT_EQ(s2.trials.size(), 60u);
  EXPECT_EQ(s3.trials.size(), 15u);
  EXPECT_EQ(count_task(s1, Task::kDissection), 15);
  EXPECT_EQ(count_task(s1, Task::kClip), 45);
  EXPECT_EQ(count_task(s3, Task::kClip), 0);
  EXPECT_EQ(s3.task_order, std::vector<Task>{Task::kDissection});
  // S1 and S2 form a counterbalanced pair.
  EXPECT_NE(s1.task_order.front(), s2.task_order.front());
  for (const auto& pp : plan.participants) EXPECT_LE(longest_run(pp.trials), kMaxRun);
  EXPECT_EQ(all_trials(plan).size(), 135u);

  // Full parameters travel with the plan (Table 3.1 friction level).
  const auto it = std::find_if(s2.settings.begin(), s2.settings.end(),
                               [](const NamedSettings& s) { return s.name == "Friction"; });
  ASSERT_NE(it, s2.settings.end());
  EXPECT_DOUBLE_EQ(it->engine.translation.friction.dynamic_level, 0.45);
}

TEST(ProtocolExamplesTest, ThesisPlannedEightIsBalancedAtLeastAsWellAsTable32) {
  const Protocol p = load_protocol_file(kDir / "thesis_planned_8.json");
  ASSERT_EQ(p.design.type, DesignType::kIncomplete);
  const StudyPlan plan = make_study_plan(p);
  ASSERT_EQ(plan.participants.size(), 8u);

  // Optional settings: those not required, in protocol order.
  std::vector<std::string> optional;
  for (const auto& s : p.settings) {
    if (std::find(p.design.required.begin(), p.design.required.end(), s.settings.name) == p.design.required.end()) {
      optional.push_back(s.settings.name);
    }
  }
  ASSERT_EQ(optional.size(), 5u);
  std::vector<std::vector<std::size_t>> subsets;
  for (const auto& pp : plan.participants) {
    ASSERT_EQ(pp.settings.size(), 5u);
    std::vector<std::size_t> mine;
    for (const auto& s : pp.settings) {
      if (p.design.required.end() !=
          std::find(p.design.required.begin(), p.design.required.end(), s.name)) {
        continue;
      }
      mine.push_back(static_cast<std::size_t>(std::find(optional.begin(), optional.end(), s.name) -
                                              optional.begin()));
    }
    ASSERT_EQ(mine.size(), 2u);
    subsets.push_back(mine);
    EXPECT_EQ(pp.trials.size(), 60u);
    EXPECT_LE(longest_run(pp.trials), kMaxRun);
  }
  const DesignBalance b = design_balance(subsets, 5);
  EXPECT_LE(b.item_spread, 1);  // Table 3.2: 3,3,4,3,3
  EXPECT_LE(b.pair_spread, 1);  // Table 3.2: 8 pairs once, 2 never

  int dissection_first = 0;
  for (const auto& pp : plan.participants) dissection_first += pp.task_order.front() == Task::kDissection;
  EXPECT_EQ(dissection_first, 4);
}

TEST(ProtocolExamplesTest, PilotCompleteDesign) {
  const Protocol p = load_protocol_file(kDir / "pilot_complete.json");
  const StudyPlan plan = make_study_plan(p);
  ASSERT_EQ(plan.participants.size(), 4u);
  for (const auto& pp : plan.participants) {
    EXPECT_EQ(pp.settings.size(), 3u);
    EXPECT_EQ(pp.trials.size(), 12u);
    EXPECT_EQ(pp.training_trials, 5);
    EXPECT_EQ(pp.task_order, std::vector<Task>{Task::kClip});
  }
  EXPECT_EQ(p.settings[2].source, "inline");
  EXPECT_DOUBLE_EQ(p.settings[2].settings.engine.translation.friction.dynamic_level, 0.9);
}

TEST(ProtocolExamplesTest, QuickThesisIsTheAsRunDesignWithTwoRepetitions) {
  const Protocol full = load_protocol_file(kDir / "thesis_as_run.json");
  const Protocol quick = load_protocol_file(kDir / "thesis_quick.json");
  EXPECT_EQ(quick.repetitions_of(Task::kDissection), 2);
  EXPECT_EQ(quick.repetitions_of(Task::kClip), 2);
  EXPECT_EQ(quick.seed, full.seed);
  ASSERT_EQ(quick.participants.size(), full.participants.size());
  for (std::size_t i = 0; i < quick.participants.size(); ++i) {
    EXPECT_EQ(quick.participants[i].code, full.participants[i].code);
    EXPECT_EQ(quick.participants[i].tasks, full.participants[i].tasks);
    EXPECT_EQ(quick.participants[i].training_trials, full.participants[i].training_trials);
  }
  EXPECT_EQ(quick.design.assignments, full.design.assignments);
  // 5 settings x (2 + 2) for S1 and S2, 5 x 2 for S3 (dissection only).
  std::size_t trials = 0;
  for (const auto& p : make_study_plan(quick).participants) trials += p.trials.size();
  EXPECT_EQ(trials, 50u);
}

TEST(ProtocolExamplesTest, EveryShippedProtocolLoadsAndPlans) {
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kDir)) {
    if (entry.path().extension() != ".json") continue;
    const StudyPlan plan = make_study_plan(load_protocol_file(entry.path()));
    EXPECT_FALSE(plan.participants.empty()) << entry.path();
    ++count;
  }
  EXPECT_EQ(count, 12);  // thesis_as_run, thesis_quick, thesis_planned_8, pilot_complete, external_peg_touch,
                        // null_setting_check, calibration, friction_dose, friction_staircase, device_comparison,
                        // transfer_study, transfer_pilot
}

// Issue 35 §4: High Fidelity against every device preset, in both tasks.
TEST(ProtocolExamplesTest, DeviceComparisonIsHighFidelityAgainstEveryDevicePreset) {
  const Protocol p = load_protocol_file(kDir / "device_comparison.json");
  std::set<std::string> devices;
  for (const auto& entry : std::filesystem::directory_iterator(kDir.parent_path() / "settings" / "devices"))
    if (entry.path().extension() == ".json") devices.insert(load_settings_file(entry.path()).name);
  ASSERT_FALSE(p.settings.empty());
  EXPECT_EQ(p.settings.front().settings.name, "High Fidelity");
  std::set<std::string> compared;
  for (std::size_t i = 1; i < p.settings.size(); ++i) {
    compared.insert(p.settings[i].settings.name);
    EXPECT_TRUE(p.settings[i].settings.source.has_value()) << p.settings[i].settings.name;
  }
  EXPECT_EQ(compared, devices);
  EXPECT_EQ(p.tasks.size(), 2u);
  EXPECT_EQ(p.design.type, DesignType::kComplete);
}

// Issue 35 §4: one component of a device at a time, each strength a setting
// that differs from High Fidelity in that component's blocks only.
TEST(ProtocolExamplesTest, ComponentDoseSeriesVaryOneComponentEach) {
  const std::map<std::string, std::set<std::string>> series = {
      {"friction.json", {"translation.friction"}},
      {"inertia.json", {"translation.inertia"}},
      {"backlash.json", {"translation.inertia", "translation.backlash"}},  // the gap needs a virtual mass
      {"latency.json", {"loop"}},
      {"update_rate.json", {"loop"}}};
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(kDir / "component_dose")) {
    if (entry.path().extension() != ".json") continue;
    ++count;
    const std::string file = entry.path().filename().string();
    ASSERT_TRUE(series.count(file)) << file;
    const Protocol p = load_protocol_file(entry.path());
    ASSERT_GE(p.settings.size(), 4u) << file;  // the control and at least 3 strengths
    EXPECT_EQ(p.settings.front().settings.name, "High Fidelity");
    const nlohmann::json control = settings_to_json(p.settings.front().settings);
    for (std::size_t i = 1; i < p.settings.size(); ++i) {
      const nlohmann::json dose = settings_to_json(p.settings[i].settings);
      std::set<std::string> differ;
      for (const char* axis : {"translation", "rotation"})
        for (const auto& [block, value] : dose[axis].items())
          if (value != control[axis][block]) differ.insert(std::string(axis) + "." + block);
      for (const char* block : {"tip_force_saturation", "loop", "device_limits"})
        if (dose[block] != control[block]) differ.insert(block);
      EXPECT_EQ(differ, series.at(file)) << p.settings[i].settings.name;
    }
    EXPECT_EQ(make_study_plan(p).participants.size(), 8u) << file;
  }
  EXPECT_EQ(count, 5);
}

TEST(ProtocolExamplesTest, ExternalPegTouchIsTheLabsOwnTask) {
  const Protocol p = load_protocol_file(kDir / "external_peg_touch.json");
  EXPECT_EQ(p.ve, Ve::kExternal);
  EXPECT_EQ(p.tasks, std::vector<Task>{Task("peg touch")});
  // 2 settings x 2 repetitions for each of P01, P02 (examples/external_app).
  for (const auto& pp : make_study_plan(p).participants) EXPECT_EQ(pp.trials.size(), 4u);
}

}  // namespace
}  // namespace hapticlab::protocols
