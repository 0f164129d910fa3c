// Damage in a study database, found by the commands that read it, through
// the real binary: a flipped byte inside a sample chunk (only the chunk's
// checksum can tell) and a damaged index (only a full integrity_check can
// tell; quick_check does not compare an index with its table).
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/study/synthetic_study_db.h"
#include "app/cli_process.h"
#include "db/db_test_util.h"
#include "db/sqlite_handle.h"
#include "tests/testing/files.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;

std::pair<int, std::string> cli(const std::string& args) { return testing::run_cli(HAPTICLAB_CLI_PATH, args); }

// The synthetic study (tests/analysis/study/synthetic_study_db.h): 11 trials
// with samples, 10 updates per hand in one chunk each, 22 chunks. Chunk 1 is
// trial 1's left hand, ticks 0..9.
class DbIntegrityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    db_ = dir_.path() / "study.db";
    analysis::testing::build_synthetic_study(db_);
  }
  // Only while no other connection is open: the CLI runs after this returns.
  void flip_chunk_1() {
    db::Database conn(db_);
    db::testing::flip_chunk_byte(conn, 1, 40);
  }
  // Trial 1's events removed behind the back of index event_by_trial: the
  // index is redefined as empty (writable_schema), a row deleted, and the
  // definition restored, so the index keeps an entry for a row that is gone.
  // Every page stays well formed: quick_check passes, integrity_check does not.
  void damage_event_index() {
    const std::string def = "CREATE INDEX event_by_trial ON event (trial_id, t_s)";
    auto set_definition = [&](const std::string& sql) {
      db::Database conn(db_);
      conn.exec("PRAGMA writable_schema = ON");
      conn.prepare("UPDATE sqlite_schema SET sql = ?1 WHERE name = 'event_by_trial'").bind(1, sql).run();
    };
    set_definition(def + " WHERE 0");
    { db::Database conn(db_); conn.exec("DELETE FROM event WHERE id = 1"); }
    set_definition(def);
    db::Database conn(db_);
    db::Statement quick = conn.prepare("PRAGMA quick_check");
    ASSERT_TRUE(quick.step());
    ASSERT_EQ(quick.column_text(0), "ok") << "the damage must be one only a full check sees";
  }

  analysis::testing::ScratchDir dir_;
  fs::path db_;
};

TEST_F(DbIntegrityTest, CheckOfACleanFileSaysSoAndExitsZero) {
  const auto [code, out] = cli("study check --db " + db_.string());
  EXPECT_EQ(code, 0) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("integrity_check: ok"),
                         HasSubstr("sample chunks: 22 checked, 0 damaged; 220 updates"), HasSubstr("no damage found")));
}

TEST_F(DbIntegrityTest, CheckNamesAFlippedByteInAChunkAndExitsOne) {
  flip_chunk_1();
  const auto [code, out] = cli("study check --db " + db_.string());
  EXPECT_EQ(code, 1) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("integrity_check: ok"), HasSubstr("22 checked, 1 damaged"),
                         HasSubstr("damaged: trial 1, left instrument (0), ticks 0..9: checksum mismatch"),
                         HasSubstr("0 integrity_check finding(s), 0 structure finding(s), 1 damaged sample chunk(s)")));
  const auto [json_code, json] = cli("study check --json --db " + db_.string() + " 2>/dev/null");
  EXPECT_EQ(json_code, 1);
  EXPECT_THAT(json, AllOf(HasSubstr("\"ok\": false"), HasSubstr("\"chunks_checked\": 22"), HasSubstr("\"trial_id\": 1"),
                          HasSubstr("\"first_tick\": 0")));
}

TEST_F(DbIntegrityTest, ExportLeavesOutADamagedChunkNamesItAndExitsOne) {
  flip_chunk_1();
  const fs::path out_dir = dir_.path() / "csv";
  const auto [code, out] = cli("export --db " + db_.string() + " --format csv --out " + out_dir.string());
  EXPECT_EQ(code, 1) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("warning: left out damaged sample chunk: trial 1, left instrument (0), ticks 0..9"),
                         HasSubstr("1 damaged sample chunk(s) (10 updates) left out of the export")));
  // Trial 1's samples file holds the right hand only: header + 10 rows, all
  // instrument 1 (the 6th column).
  fs::path samples;
  for (const auto& entry : fs::directory_iterator(out_dir))
    if (entry.path().filename().string().ends_with("_trial1_samples.csv")) samples = entry.path();
  ASSERT_FALSE(samples.empty()) << out;
  std::istringstream text(testing::slurp(samples));
  std::string line;
  std::getline(text, line);
  int rows = 0;
  while (std::getline(text, line)) {
    ++rows;
    std::istringstream fields(line);
    std::string field;
    for (int i = 0; i < 6; ++i) std::getline(fields, field, ',');
    EXPECT_EQ(field, "1") << line;
  }
  EXPECT_EQ(rows, 10);
}

// The outputs hold the rest; exit 1, as export, so that a script does not
// take the results for the whole study's.
TEST_F(DbIntegrityTest, AnalyzeLeavesOutTheDamagedTrialWarnsAndExitsOne) {
  flip_chunk_1();
  const fs::path out_dir = dir_.path() / "analysis";
  const auto [code, out] = cli("analyze --db " + db_.string() + " --out " + out_dir.string() + " --no-plots --no-ks");
  EXPECT_EQ(code, 1) << out;
  EXPECT_THAT(out, HasSubstr("1 damaged sample chunk(s) left out, listed above: the results in "));
  EXPECT_THAT(out, AllOf(HasSubstr("warning: left out damaged sample chunk: trial 1, left instrument (0), ticks 0..9"),
                         HasSubstr("(1 damaged sample chunk(s) left out)")));
  EXPECT_THAT(testing::slurp(out_dir / "metrics.csv"), HasSubstr("1 damaged sample chunk(s) left out"));
}

// Format 2 with a right checksum over bytes that are no zstd frame (a
// writer that got it wrong): named like damage, left out and counted.
TEST_F(DbIntegrityTest, AFrameThatDoesNotDecompressIsNamedLeftOutAndCounted) {
  {
    db::Database conn(db_);
    const std::string garbage = "not a zstd frame";
    db::testing::resign_chunk(conn, 1, db::kChunkFormat, std::as_bytes(std::span(garbage)));
  }
  const auto [code, out] = cli("study check --db " + db_.string());
  EXPECT_EQ(code, 1) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("22 checked, 1 damaged"),
                         HasSubstr("damaged: trial 1, left instrument (0), ticks 0..9: the zstd frame does not "
                                   "decompress")));
  const fs::path out_dir = dir_.path() / "analysis";
  const auto [analysed, analysis] =
      cli("analyze --db " + db_.string() + " --out " + out_dir.string() + " --no-plots --no-ks");
  EXPECT_EQ(analysed, 1) << analysis;
  EXPECT_THAT(analysis, AllOf(HasSubstr("left out damaged sample chunk: trial 1, left instrument (0), ticks 0..9"),
                              HasSubstr("(1 damaged sample chunk(s) left out)")));
}

// A chunk of a format from a newer HapticLab, correctly signed: analyze
// refuses the study naming the format and the trial, rather than answer
// without those samples; study check names it too.
TEST_F(DbIntegrityTest, AChunkOfAnUnknownFormatIsRefusedWithItsVersionAndTrial) {
  {
    db::Database conn(db_);
    const std::string body(40, 'x');
    db::testing::resign_chunk(conn, 1, 9, std::as_bytes(std::span(body)));
  }
  const auto [code, out] =
      cli("analyze --db " + db_.string() + " --out " + (dir_.path() / "analysis").string() + " --no-plots --no-ks");
  EXPECT_EQ(code, 1) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("cannot analyse this study: trial 1, left instrument (0), ticks 0..9"),
                         HasSubstr("chunk format 9 is not one this HapticLab reads (0, 1, 3)")));
  const auto [checked, check_out] = cli("study check --db " + db_.string());
  EXPECT_EQ(checked, 1) << check_out;
  EXPECT_THAT(check_out, HasSubstr("trial 1, left instrument (0), ticks 0..9: chunk format 9"));
}

TEST_F(DbIntegrityTest, EveryReaderRefusesADamagedIndex) {
  damage_event_index();
  const std::string db = " --db " + db_.string();
  const std::string out = (dir_.path() / "out").string();
  for (const std::string& args : {"study show" + db, "export" + db + " --format csv --out " + out,
                                  "analyze" + db + " --out " + out + " --no-plots --no-ks",
                                  "sim replay" + db + " --trial 1 --out " + out + ".csv"}) {
    const auto [code, text] = cli(args);
    EXPECT_EQ(code, 1) << args << "\n" << text;
    EXPECT_THAT(text, AllOf(HasSubstr("integrity_check found"), HasSubstr("event_by_trial"))) << args;
  }
  const auto [code, text] = cli("study check" + db);
  EXPECT_EQ(code, 1) << text;
  EXPECT_THAT(text, AllOf(HasSubstr("integrity_check: 1 finding(s)"), HasSubstr("event_by_trial")));
}

}  // namespace
}  // namespace hapticlab::app
