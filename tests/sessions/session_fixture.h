#pragma once
// Shared by the sessions tests: a temporary directory holding a small
// protocol (two settings of the shipped examples, two participants,
// dissection only) and a study database created from it.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "db/study_db.h"
#include "sessions/session_runner.h"
#include "sessions/study_setup.h"

namespace hapticlab::sessions::testing {

inline std::filesystem::path source_dir() {
  if (const char* env = std::getenv("HAPTICLAB_SOURCE_DIR")) return env;
  return HAPTICLAB_SOURCE_DIR;
}

class SessionFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("hapticlab_sessions_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    const std::filesystem::path settings = source_dir() / "examples" / "settings";
    protocol_ = dir_ / "protocol.json";
    std::ofstream(protocol_) << R"({
      "study": "session test",
      "tasks": ["dissection"],
      "repetitions": {"dissection": 2},
      "settings": [")" << (settings / "high_fidelity.json").string()
                             << R"(", ")" << (settings / "no_force_feedback.json").string() << R"("],
      "participants": ["A1", {"code": "B2", "training_trials": 2}],
      "design": {"type": "complete"},
      "seed": 11
    })";
    db_path_ = dir_ / "study.db";
    db::StudyDb db(db_path_);
    create_study(db, protocol_, "test");
  }
  void TearDown() override {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }

  std::filesystem::path dir_, protocol_, db_path_;
};

// A session of `code` without training: what most tests run.
inline SessionOptions options_for(const std::string& code) {
  SessionOptions o;
  o.participant = code;
  o.training_trials = 0;
  return o;
}

}  // namespace hapticlab::sessions::testing
