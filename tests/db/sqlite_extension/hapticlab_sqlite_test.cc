// The SQLite extension (db/sqlite_extension) loaded by the real `sqlite3`
// shell into a study database from a real session (`hapticlab study create`
// and `session run`, one trial): its rows equal `hapticlab export`'s CSV bit
// for bit, the ways of asking (arguments, WHERE, a join) agree, and a
// damaged chunk or a wrong argument is an error that says what is wrong.
#include <unistd.h>

#include <bit>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "db/db_test_util.h"
#include "db/sample_codec.h"
#include "db/sqlite_handle.h"
#include "testing/csv_rows.h"
#include "tests/testing/files.h"

namespace hapticlab::db {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kHapticlab = HAPTICLAB_CLI_PATH;
const std::string kSqlite3 = HAPTICLAB_SQLITE3_CLI;
const std::string kExtension = HAPTICLAB_SQLITE_EXTENSION;

std::vector<std::vector<std::string>> csv_lines(const std::string& text) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    rows.push_back(hapticlab::testing::split_csv_line(line));
  }
  return rows;
}

using hapticlab::testing::slurp;

// One shell word (POSIX sh single quotes).
std::string shell_word(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// One study with one trial run, built once for the whole suite, and its
// export. The session is deterministic only up to the virtual clock, so the
// test compares against the export of this very file, never stored numbers.
class SqliteExtensionTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("hapticlab_sqlite_ext_" + std::to_string(::getpid())));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
    db_ = new std::string((*dir_ / "study.db").string());
    for (const std::string& args :
         {"study create --protocol " + std::string(HAPTICLAB_SOURCE_DIR) + "/examples/protocols/thesis_quick.json --db " +
              *db_,
          // 250 Hz: fewer rows to compare, the same chunks' layout.
          "session run --db " + *db_ + " --participant S1 --training-trials 0 --max-trials 1 --rate-hz 250",
          "export --db " + *db_ + " --trial 1 --format csv --out " + (*dir_ / "csv").string()}) {
      const auto [status, out] = hapticlab::testing::run_cli(kHapticlab, args);
      ASSERT_EQ(status, 0) << args << "\n" << out;
    }
    for (const auto& e : fs::directory_iterator(*dir_ / "csv"))
      if (e.path().string().ends_with("_samples.csv")) export_ = new fs::path(e.path());
    ASSERT_NE(export_, nullptr);
  }
  // The suite's study must exist (a failed SetUpTestSuite fails every test).
  void SetUp() override { ASSERT_NE(export_, nullptr) << "the study could not be built; see the first test's output"; }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
    delete db_;
    delete export_;
  }

  // `sqlite3 -bail -csv -header DB ".load EXT" SQL...`, stderr folded in.
  static std::pair<int, std::string> sql(const std::string& db, const std::vector<std::string>& statements) {
    std::string args = "-bail -csv -header " + shell_word(db) + " " + shell_word(".load " + kExtension);
    for (const auto& s : statements) args += " " + shell_word(s);
    return hapticlab::testing::run_cli(kSqlite3, args);
  }

  // A copy of the study to damage (VACUUM INTO keeps the schema version
  // and application id).
  static std::string copy_of_study(const std::string& name) {
    const std::string copy = (*dir_ / name).string();
    fs::remove(copy);
    Database(*db_).exec("VACUUM INTO '" + copy + "'");
    return copy;
  }

  static fs::path* dir_;
  static std::string* db_;
  static fs::path* export_;
};
fs::path* SqliteExtensionTest::dir_ = nullptr;
std::string* SqliteExtensionTest::db_ = nullptr;
fs::path* SqliteExtensionTest::export_ = nullptr;

// Channel kinds in kChannelNames order (sample_codec.h): float64, float32, integer.
bool is_float64(std::size_t c) { return c < 2; }
bool is_float32(std::size_t c) { return c >= 2 && c < 25; }

TEST_F(SqliteExtensionTest, RowsEqualTheExportCsvBitForBit) {
  // The shell prints REALs with 15 digits, so each REAL column is asked for
  // as its IEEE-754 bit pattern (the shell's ieee754_to_blob), read back
  // here exactly; NaN would be NULL (SQLite has none) and print empty.
  std::string select = "SELECT trial_id, instrument, tick";
  for (std::size_t c = 0; c < kChunkChannels; ++c) {
    const std::string name = kChannelNames[c];
    select += c < 25 ? ", hex(ieee754_to_blob(" + name + ")) AS " + name : ", " + name;
  }
  const auto [status, out] = sql(*db_, {select + " FROM samples(1)"});
  ASSERT_EQ(status, 0) << out.substr(0, 2000);
  const auto rows = csv_lines(out);
  const auto csv = csv_lines(slurp(*export_));
  ASSERT_GT(csv.size(), 1000u) << "the trial must have stored samples";
  ASSERT_EQ(rows.size(), csv.size()) << "row count (header included)";

  // The same column names as the export, which adds four text keys after trial_id.
  std::vector<std::string> expected_header = {csv[0][0]};
  expected_header.insert(expected_header.end(), csv[0].begin() + 5, csv[0].end());
  EXPECT_EQ(rows[0], expected_header);

  std::size_t checked = 0;
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const auto& got = rows[r];
    const auto& want = csv[r];
    ASSERT_EQ(got.size(), 3 + kChunkChannels) << r;
    ASSERT_EQ(want.size(), 7 + kChunkChannels) << r;
    ASSERT_EQ(got[0], want[0]) << "trial_id, row " << r;
    ASSERT_EQ(got[1], want[5]) << "instrument, row " << r;
    ASSERT_EQ(got[2], want[6]) << "tick, row " << r;
    for (std::size_t c = 0; c < kChunkChannels; ++c) {
      const std::string& g = got[3 + c];
      const std::string& w = want[7 + c];
      if (is_float64(c) || is_float32(c)) {
        // Export text read back as the stored type (float32 channels as
        // float: the CSV holds the shortest text of the float).
        const double stored = is_float64(c) ? std::strtod(w.c_str(), nullptr) : double{std::strtof(w.c_str(), nullptr)};
        ASSERT_EQ(g.size(), 16u) << kChannelNames[c] << " row " << r << ": '" << g << "' vs export '" << w << "'";
        const std::uint64_t bits = std::stoull(g, nullptr, 16);
        ASSERT_EQ(bits, std::bit_cast<std::uint64_t>(stored))
            << kChannelNames[c] << " row " << r << ": SQL " << std::bit_cast<double>(bits) << " vs export " << w;
      } else {
        ASSERT_EQ(g, w) << kChannelNames[c] << " row " << r;
      }
      ++checked;
    }
  }
  EXPECT_EQ(checked, (rows.size() - 1) * kChunkChannels);
}

TEST_F(SqliteExtensionTest, ArgumentsWhereClauseAndJoinAgree) {
  const auto csv = csv_lines(slurp(*export_));
  std::size_t left = 0, right = 0;
  for (std::size_t r = 1; r < csv.size(); ++r) (csv[r][5] == "0" ? left : right) += 1;
  ASSERT_GT(left, 0u);
  ASSERT_GT(right, 0u);
  const auto [status, out] = sql(*db_, {
      ".headers off",
      "SELECT count(*) FROM samples(1, 0)",
      "SELECT count(*), min(instrument), max(instrument) FROM samples(1, 1)",
      "SELECT count(*) FROM samples WHERE trial_id = 1 AND instrument = 0",
      "SELECT count(*) FROM samples",  // every trial: only trial 1 has samples
      "SELECT t.id, count(*) FROM trial t, samples(t.id) s WHERE t.status = 'complete' GROUP BY t.id",
      "SELECT count(*) FROM samples(1.0)",  // an integral real is the integer
      "SELECT count(*) FROM samples(NULL)",  // matches nothing, as trial_id = NULL would
  });
  ASSERT_EQ(status, 0) << out;
  const std::string n = std::to_string(left + right);
  EXPECT_EQ(out, std::to_string(left) + "\n" + std::to_string(right) + ",1,1\n" + std::to_string(left) + "\n" + n +
                     "\n1," + n + "\n" + n + "\n0\n");
}

TEST_F(SqliteExtensionTest, ADamagedChunkIsAnErrorNamingTrialInstrumentAndTicksAndGivesNoRow) {
  const std::string copy = copy_of_study("damaged.db");
  std::int64_t chunk = 0, first = 0, count = 0;
  {
    Database conn(copy);
    // The right instrument's second chunk: not the first row a scan meets.
    Statement s = conn.prepare(
        "SELECT id, first_tick, count FROM sample_chunk WHERE trial_id = 1 AND instrument = 1 "
        "ORDER BY first_tick LIMIT 1 OFFSET 1");
    ASSERT_TRUE(s.step());
    chunk = s.column_int64(0);
    first = s.column_int64(1);
    count = s.column_int64(2);
    testing::flip_chunk_byte(conn, chunk, 40);
  }
  const std::string named = "damaged sample chunk: trial 1, right instrument (1), ticks " + std::to_string(first) +
                            ".." + std::to_string(first + count - 1) + ": checksum mismatch";
  for (const char* query : {"SELECT tick FROM samples(1)", "SELECT tick FROM samples(1, 1)",
                                   "SELECT count(*) FROM samples(1)", "SELECT max(ve_force_z_N) FROM samples"}) {
    const auto [status, out] = sql(copy, {".headers off", query});
    EXPECT_NE(status, 0) << query << "\n" << out;
    EXPECT_THAT(out, HasSubstr(named)) << query;
    // Verified before the trial's first row: no row at all, not rows up to the damage.
    EXPECT_THAT(out, Not(::testing::ContainsRegex("^[0-9]"))) << query << "\n" << out.substr(0, 200);
  }
  // The undamaged left instrument still reads.
  const auto [status, out] = sql(copy, {".headers off", "SELECT count(*) > 1000 FROM samples(1, 0)"});
  EXPECT_EQ(status, 0) << out;
  EXPECT_EQ(out, "1\n");
}

// A chunk whose checksum is right but that does not decode (its frame
// changed and the CRC recomputed, or written wrong), late in the trial:
// every chunk is verified and decompressed before the trial's first row, so
// the query fails with no row at all (it used to print the rows before it).
TEST_F(SqliteExtensionTest, AChunkThatDoesNotDecodeLateInTheTrialGivesNoRow) {
  const std::string copy = copy_of_study("undecodable.db");
  std::int64_t first = 0, count = 0;
  {
    Database conn(copy);
    Statement s = conn.prepare(
        "SELECT id, first_tick, count FROM sample_chunk WHERE trial_id = 1 AND instrument = 1 "
        "ORDER BY first_tick DESC LIMIT 1");
    ASSERT_TRUE(s.step());
    first = s.column_int64(1);
    count = s.column_int64(2);
    const std::string garbage = "not a zstd frame";
    testing::resign_chunk(conn, s.column_int64(0), kChunkFormat, std::as_bytes(std::span(garbage)));
  }
  for (const char* query : {"SELECT tick FROM samples(1)", "SELECT tick FROM samples(1, 1)"}) {
    const auto [status, out] = sql(copy, {".headers off", query});
    EXPECT_NE(status, 0) << query;
    EXPECT_THAT(out, AllOf(HasSubstr(copy + ": damaged sample chunk: trial 1, right instrument (1), ticks " +
                                     std::to_string(first) + ".." + std::to_string(first + count - 1) +
                                     ": the zstd frame does not decompress"),
                           HasSubstr("no row of the trial is returned")))
        << query;
    EXPECT_THAT(out, Not(::testing::ContainsRegex("^[0-9]"))) << query << "\n" << out.substr(0, 200);
  }
}

// A removed chunk left nothing to verify: samples(1) returned the trial
// 1,000 rows shorter. The extension checks what the file says the trial
// stored (db/chunk_coverage_rules.h), like every other reader.
TEST_F(SqliteExtensionTest, ARemovedChunkIsAnErrorNamingTheMissingTicksNotAShorterTrial) {
  for (const char* which : {"OFFSET 1", "DESC"}) {  // between two chunks; the last one
    const std::string copy = copy_of_study("removed.db");
    std::int64_t first = 0, count = 0;
    {
      Database conn(copy);
      Statement s = conn.prepare(std::string("SELECT id, first_tick, count FROM sample_chunk WHERE trial_id = 1 AND "
                                             "instrument = 0 ORDER BY first_tick ") +
                                 (std::string(which) == "DESC" ? "DESC LIMIT 1" : "LIMIT 1 OFFSET 1"));
      ASSERT_TRUE(s.step());
      first = s.column_int64(1);
      count = s.column_int64(2);
      conn.exec("DELETE FROM sample_chunk WHERE id = " + std::to_string(s.column_int64(0)));
    }
    const std::string ticks = "trial 1, left instrument (0), ticks " + std::to_string(first) + "..";
    for (const char* query : {"SELECT tick FROM samples(1)", "SELECT tick FROM samples(1, 0)",
                              "SELECT count(*) FROM samples WHERE trial_id = 1"}) {
      const auto [status, out] = sql(copy, {".headers off", query});
      EXPECT_NE(status, 0) << which << ": " << query << "\n" << out.substr(0, 300);
      EXPECT_THAT(out, AllOf(HasSubstr(ticks), HasSubstr("not stored"), HasSubstr("(a chunk was removed)"),
                             HasSubstr("no row of the trial is returned")))
          << which << ": " << query;
      EXPECT_THAT(out, Not(::testing::ContainsRegex("^[0-9]"))) << query << "\n" << out.substr(0, 200);
    }
    // The right instrument's updates are all there: it still reads.
    const auto [status, out] = sql(copy, {".headers off", "SELECT count(*) > 1000 FROM samples(1, 1)"});
    EXPECT_EQ(status, 0) << out;
    EXPECT_EQ(out, "1\n") << which;
    if (std::string(which) == "OFFSET 1") {
      // The gap's own ticks, exactly.
      const auto [gap_status, gap_out] = sql(copy, {".headers off", "SELECT 1 FROM samples(1, 0)"});
      EXPECT_THAT(gap_out, HasSubstr(ticks + std::to_string(first + count - 1) + ": not stored, and no "
                                     "samples_missing event accounts for them"));
    }
  }
}

TEST_F(SqliteExtensionTest, WrongArgumentsAndForeignFilesAreNamedErrors) {
  {
    const auto [status, out] = sql(*db_, {"SELECT * FROM samples(99)"});
    EXPECT_NE(status, 0);
    EXPECT_THAT(out, HasSubstr("samples(): trial_id is 99, but the study database " + *db_ + " has no such trial"));
  }
  {
    const auto [status, out] = sql(*db_, {"SELECT * FROM samples(1, 2)"});
    EXPECT_NE(status, 0);
    EXPECT_THAT(out, HasSubstr("samples(): instrument is 2; it must be 0 (left) or 1 (right)"));
  }
  // No rows would read as an empty trial: an argument that is no trial id
  // is named too (a table's `WHERE trial_id = 3.5` still just matches
  // nothing, and NULL matches nothing, as trial_id = NULL would).
  for (const auto& [query, says] : std::vector<std::pair<std::string, std::string>>{
           {"SELECT * FROM samples(1.7)", "samples(): trial_id is 1.7; it must be an integer, the id of a trial"},
           {"SELECT * FROM samples('abc')", "samples(): trial_id is abc; it must be an integer"}}) {
    const auto [status, out] = sql(*db_, {query});
    EXPECT_NE(status, 0) << query;
    EXPECT_THAT(out, HasSubstr(says)) << query;
  }
  {
    const auto [status, out] = sql(*db_, {".headers off", "SELECT count(*) FROM samples WHERE trial_id = 3.5"});
    EXPECT_EQ(status, 0) << out;
    EXPECT_EQ(out, "0\n");
  }
  {
    // A planned trial has no samples yet: no rows, no error.
    const auto [status, out] = sql(*db_, {".headers off", "SELECT count(*) FROM samples(2)"});
    EXPECT_EQ(status, 0) << out;
    EXPECT_EQ(out, "0\n");
  }
  {
    const std::string other = (*dir_ / "other.db").string();
    Database(other).exec("CREATE TABLE IF NOT EXISTS t(x)");
    const auto [status, out] = sql(other, {"SELECT * FROM samples(1)"});
    EXPECT_NE(status, 0);
    EXPECT_THAT(out, HasSubstr("samples: " + other + " is not a HapticLab study database (application_id 0"));
  }
  {
    const std::string old = copy_of_study("old.db");
    Database(old).exec("PRAGMA user_version = 6");
    const auto [status, out] = sql(old, {"SELECT * FROM samples(1)"});
    EXPECT_NE(status, 0);
    EXPECT_THAT(out, AllOf(HasSubstr("schema version 6, this extension reads version 11"), HasSubstr("hapticlab analyze")));
  }
}

}  // namespace
}  // namespace hapticlab::db
