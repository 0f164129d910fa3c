#pragma once
// What the tests of `plan power` and `plan merge` share: a small protocol
// in a folder of the test's own, the binary run with it, and plan_power.db
// read or edited through SQLite as any client could.
#include <sqlite3.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "tests/app/cli_process.h"
#include "tests/testing/sqlite_edit.h"

namespace hapticlab::app {

namespace fs = std::filesystem;

inline fs::path source_dir() {
  if (const char* env = std::getenv("HAPTICLAB_SOURCE_DIR")) return env;
  return HAPTICLAB_SOURCE_DIR;
}

// Studies stored so far, read through SQLite (read-only), as any reader may.
inline int stored_studies(const fs::path& db) {
  sqlite3* c = nullptr;
  if (sqlite3_open_v2(db.c_str(), &c, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    sqlite3_close(c);
    return -1;
  }
  sqlite3_busy_timeout(c, 2000);
  sqlite3_stmt* s = nullptr;
  int n = -1;
  if (sqlite3_prepare_v2(c, "SELECT count(*) FROM study", -1, &s, nullptr) == SQLITE_OK && sqlite3_step(s) == SQLITE_ROW)
    n = sqlite3_column_int(s, 0);
  sqlite3_finalize(s);
  sqlite3_close(c);
  return n;
}

// Runs `sql` on a plan_power.db as any SQLite client could (checksums and
// constraints are the file's own business): how the damaged copies are made.
inline void edit_plan_db(const fs::path& db, const std::string& sql) { testing::edit_with_sqlite(db, sql); }

class PlanPowerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("hapticlab_plan_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    protocol_ = write_protocol("tiny.json", "high_fidelity.json");
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  // A small study: one task, 2 repetitions of 2 settings, 2 participants.
  fs::path write_protocol(const std::string& name, const std::string& first_setting) {
    const fs::path settings = source_dir() / "examples" / "settings";
    const fs::path p = dir_ / name;
    std::ofstream(p) << R"({"study": "tiny", "tasks": ["clip"], "repetitions": {"clip": 2}, "settings": [")"
                     << (settings / first_setting).string() << R"(", ")"
                     << (settings / "no_force_feedback.json").string()
                     << R"("], "participants": ["A", "B"], "design": {"type": "complete"}, "seed": 5})";
    return p;
  }
  // The loop at 250 Hz: what these tests show (the same table on any
  // thread count, resumed after a kill or a full disk) does not depend on
  // the rate, and the simulation dominates their time (8x slower under the
  // sanitizers than in release).
  static constexpr const char* kRate = " --rate-hz 250 ";
  std::pair<int, std::string> plan(const std::string& args) {
    return testing::run_cli(HAPTICLAB_CLI_PATH, "plan power --protocol " + protocol_.string() + kRate + args);
  }
  fs::path dir_, protocol_;
};

}  // namespace hapticlab::app
