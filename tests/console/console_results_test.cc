// The Results page's jobs (console/console_results.h) on a study with a
// damaged sample chunk: the analysis and the export are done for the rest
// and say they are incomplete, as `hapticlab analyze` and `export` exit 1;
// they said "done" before.
#include "console/console_results.h"

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/study/synthetic_study_db.h"
#include "db/db_test_util.h"
#include "db/sqlite_handle.h"

namespace hapticlab::console {
namespace {

using ::testing::HasSubstr;

nlohmann::json wait_for_job(const ConsoleResults& results) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  nlohmann::json s = results.status();
  while (s["state"] == "running" && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    s = results.status();
  }
  return s;
}

TEST(ConsoleResultsTest, ADamagedChunkMakesTheAnalysisAndTheExportIncompleteNotDone) {
  analysis::testing::ScratchDir dir;
  const std::filesystem::path db = dir.path() / "study.db";
  analysis::testing::build_synthetic_study(db);
  {
    ConsoleResults clean(db, dir.path() / "clean");
    clean.start(false);
    EXPECT_EQ(wait_for_job(clean)["state"], "done");
  }
  {
    db::Database conn(db);
    db::testing::flip_chunk_byte(conn, 1, 40);  // trial 1's left hand
  }
  ConsoleResults results(db, dir.path() / "results");
  results.start(false);
  nlohmann::json s = wait_for_job(results);
  EXPECT_EQ(s["state"], "incomplete") << s.dump();
  EXPECT_THAT(s["message"].get<std::string>(), HasSubstr("1 damaged sample chunk(s) left out"));
  EXPECT_THAT(s["files"].dump(), HasSubstr("metrics.csv"));  // the rest is there
  results.start_export("", 1, false);
  s = wait_for_job(results);
  EXPECT_EQ(s["state"], "incomplete") << s.dump();
  EXPECT_THAT(s["message"].get<std::string>(), HasSubstr("1 damaged sample chunk(s) (10 updates) left out"));
}

}  // namespace
}  // namespace hapticlab::console
