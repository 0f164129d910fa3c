#pragma once
// The set-up the plan runner's and the shard merge's tests share: a test's
// own scratch folder holding a small plan's protocol (the clip task once at
// High Fidelity and No Force Feedback, two participants, a complete design,
// seed 7), loaded, and simulated studies at 150 Hz.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "planning/simulated_study.h"
#include "protocols/protocol_json.h"
#include "testing/scratch_dir.h"

namespace hapticlab::planning {

class TwoSettingPlanTest : public ::testing::Test {
 protected:
  // `study` names the protocol's study (it titles the plan's comparison).
  explicit TwoSettingPlanTest(const std::string& study) : dir_(scratch_.path()) {
    const std::filesystem::path settings = std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings";
    protocol_path_ = dir_ / "protocol.json";
    std::ofstream(protocol_path_) << R"({"study": ")" << study << R"(", "tasks": ["clip"], "repetitions": {"clip": 1},
      "settings": [")" << (settings / "high_fidelity.json").string() << R"(", ")"
                                  << (settings / "no_force_feedback.json").string() << R"("],
      "participants": ["P01", "P02"], "design": {"type": "complete"}, "training_trials": 0, "seed": 7})";
    protocol_ = protocols::load_protocol_file(protocol_path_.string());
    sim_.rate_Hz = 150.0;
  }

  testing::ScratchDir scratch_;
  std::filesystem::path dir_;
  std::filesystem::path protocol_path_;
  protocols::Protocol protocol_;
  SimulatedStudyOptions sim_;
};

}  // namespace hapticlab::planning
