// `hapticlab demo --quick` end to end, through the real binary: the
// database, the metrics CSV and the report exist and agree with each other
// and with the protocol; a demo (of a smaller protocol) killed halfway
// resumes instead of starting over.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "testing/csv_rows.h"
#include "db/study_db.h"
#include "protocols/protocol_json.h"
#include "protocols/schedule.h"
#include "tests/testing/test_paths.h"
#include "tests/testing/files.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;


fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("hapticlab_demo_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

// Runs the binary with `args`; returns its exit status and output.
std::pair<int, std::string> run(const std::string& args) { return testing::run_cli(kBinary, args); }

using testing::slurp;

const fs::path kQuickProtocol = fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "protocols" / "thesis_quick.json";

// What a protocol file plans.
protocols::StudyPlan plan_of(const fs::path& protocol) {
  return protocols::make_study_plan(protocols::load_protocol_file(protocol));
}

// A smaller study than the quick demo's 50 trials, with what its report
// needs for every table (two tasks for Tables 3.5 and 3.6): 18 trials, for
// the test whose point is the kill and the resume, not the shipped protocol.
fs::path write_small_protocol(const fs::path& dir) {
  const fs::path settings = fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings";
  fs::create_directories(dir);
  const fs::path p = dir / "small.json";
  std::ofstream(p) << R"({"study": "demo resume", "tasks": ["dissection", "clip"],)"
                   << R"( "repetitions": {"dissection": 1, "clip": 2}, "settings": [")"
                   << (settings / "high_fidelity.json").string() << R"(", ")"
                   << (settings / "no_force_feedback.json").string() << R"(", ")"
                   << (settings / "friction.json").string()
                   << R"("], "participants": ["S1", "S2"], "design": {"type": "complete"}, "seed": 5})";
  return p;
}

void expect_consistent_outputs(const fs::path& out, const fs::path& protocol = kQuickProtocol) {
  const protocols::StudyPlan plan = plan_of(protocol);
  std::set<std::string> planned_codes;
  std::size_t planned_trials = 0;
  for (const auto& p : plan.participants) {
    planned_codes.insert(p.code);
    planned_trials += p.trials.size();
  }

  ASSERT_TRUE(fs::exists(out / "study.db"));
  db::OpenOptions open;
  open.recover = false;
  db::StudyDb db(out / "study.db", open);
  const auto trials = db.trials();
  std::set<std::string> db_codes;
  std::size_t complete = 0;
  for (const auto& t : trials) {
    db_codes.insert(t.participant_code);
    complete += t.status == db::TrialStatus::kComplete ? 1 : 0;
  }
  EXPECT_EQ(db_codes, planned_codes);
  EXPECT_EQ(complete, planned_trials);  // every planned slot done exactly once

  const auto rows = testing::read_csv_rows(out / "metrics.csv");
  EXPECT_EQ(rows.size(), 2 * complete);  // one row per trial and hand
  std::set<std::string> csv_codes, csv_trials;
  for (const auto& r : rows) {
    csv_codes.insert(r.at("participant"));
    csv_trials.insert(r.at("trial_id"));
    EXPECT_EQ(r.at("status"), "complete");
  }
  EXPECT_EQ(csv_codes, planned_codes);
  EXPECT_EQ(csv_trials.size(), complete);

  const std::string html = slurp(out / "report.html");
  for (const char* table : {"Table 3.4", "Table 3.5", "Table 3.6", "Table 3.7"})
    EXPECT_NE(html.find(table), std::string::npos) << table;
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);  // self-contained: nothing fetched
  const std::string md = slurp(out / "report.md");
  EXPECT_NE(md.find("Table 3.4"), std::string::npos);
  for (const std::string& code : planned_codes) EXPECT_NE(html.find(code), std::string::npos) << code;
}

TEST(StudyDemoTest, QuickRunWritesAConsistentDatabaseCsvAndReport) {
  const fs::path out = fresh_dir("quick");
  const auto [status, output] = run("demo --quick --out " + out.string());
  ASSERT_EQ(status, 0) << output;
  EXPECT_NE(output.find("Table 3.4"), std::string::npos) << output;
  // Numbered as in the thesis: 3.5 is the dissection's, 3.6 the clip's
  // (the study lists clip first).
  EXPECT_NE(output.find("Table 3.5  dissection:"), std::string::npos) << output;
  EXPECT_NE(output.find("Table 3.6  clip:"), std::string::npos) << output;
  EXPECT_NE(output.find("report.html"), std::string::npos) << output;
  expect_consistent_outputs(out);

  // Run again: everything is done, nothing runs twice.
  const auto [again, output2] = run("demo --quick --out " + out.string());
  ASSERT_EQ(again, 0) << output2;
  EXPECT_NE(output2.find("Resuming"), std::string::npos) << output2;
  expect_consistent_outputs(out);
  fs::remove_all(out);
}

TEST(StudyDemoTest, KilledHalfwayResumesInsteadOfStartingOver) {
  const fs::path out = fresh_dir("killed");
  const fs::path protocol = write_small_protocol(fresh_dir("killed_protocol"));
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const std::string dir = out.string();
    std::freopen("/dev/null", "w", stdout);  // the parent reads the database, not the bar
    ::execl(kBinary.c_str(), kBinary.c_str(), "demo", "--protocol", protocol.c_str(), "--out", dir.c_str(),
            "--no-plots", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Wait until some trials are stored, then kill -9.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  std::size_t complete_before = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (!fs::exists(out / "study.db")) continue;
    try {
      db::OpenOptions open;
      open.read_only = true;  // a monitor never writes, not even the journal mode
      open.integrity = db::OpenOptions::Integrity::kSkip;
      db::StudyDb db(out / "study.db", open);
      complete_before = 0;
      for (const auto& t : db.trials()) complete_before += t.status == db::TrialStatus::kComplete ? 1 : 0;
    } catch (const std::exception&) {
      continue;  // created but not yet migrated: try again
    }
    if (complete_before >= 5) break;
  }
  ::kill(child, SIGKILL);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_GE(complete_before, 5u) << "the demo did not get going within 120 s";
  const std::size_t planned = [&] {
    std::size_t n = 0;
    for (const auto& p : plan_of(protocol).participants) n += p.trials.size();
    return n;
  }();
  ASSERT_LT(complete_before, planned) << "finished before it could be killed";

  const auto [again, output] = run("demo --protocol " + protocol.string() + " --out " + out.string());
  ASSERT_EQ(again, 0) << output;
  EXPECT_NE(output.find("Resuming"), std::string::npos) << output;
  EXPECT_NE(output.find("already complete"), std::string::npos) << output;
  expect_consistent_outputs(out, protocol);
  fs::remove_all(out);
  fs::remove_all(protocol.parent_path());
}

}  // namespace
}  // namespace hapticlab
