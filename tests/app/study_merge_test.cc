// `hapticlab study merge` through the real binary (issue 36 §4, §5): two
// sites' sessions run at once as separate processes on their own files, one
// killed mid-trial (SIGKILL) and resumed, then merged; the merged study is
// an ordinary one (study check, analyze, export, sim replay, the Python
// reader, the SQL extension) whose analysis is that of the same sessions
// run in one file. Bad site files are refused by name; a full disk stops
// the merge leaving no partial --out.
#include <sys/stat.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/cli_process.h"
#include "db/study_db.h"
#include "testing/child_process.h"
#include "testing/files.h"
#include "testing/scratch_dir.h"
#include "testing/sqlite_edit.h"
#include "tests/testing/test_paths.h"

namespace hapticlab {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

class StudyMergeTest : public ::testing::Test {
 protected:
  void SetUp() override { protocol_ = write_protocol("sites.json", "sites"); }

  // Two settings, one task of 2 repetitions, two participants (A1 runs at
  // site a, B1 at site b), no training: 4 trials each.
  fs::path write_protocol(const std::string& file, const std::string& study) const {
    const std::string settings = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/";
    const fs::path p = dir_.path() / file;
    std::ofstream(p) << R"({"study": ")" << study << R"(", "tasks": ["clip"], "repetitions": {"clip": 2},
      "settings": [")" << settings << R"(high_fidelity.json", ")" << settings << R"(friction.json"],
      "participants": ["A1", "B1"], "training_trials": 0, "design": {"type": "complete"}, "seed": 5})";
    return p;
  }

  std::string create(const std::string& name, const fs::path& protocol) const {
    const std::string db = (dir_.path() / name).string();
    const auto [rc, out] = testing::run_cli(kBinary, "study create --protocol " + protocol.string() + " --db " + db);
    EXPECT_EQ(rc, 0) << out;
    return db;
  }

  static std::vector<std::string> run_args(const std::string& db, const std::string& who, const std::string& clock) {
    return {kBinary, "session", "run", "--db", db, "--participant", who, "--clock", clock, "--rate-hz", "150"};
  }

  // A1 killed during its first trial, B1 run in full, at once (each on the
  // file given), then A1 resumed: the history of one site's crash.
  void run_sites(const std::string& db_a, const std::string& db_b, const std::string& tag) {
    // The killed session runs on the virtual clock through a device whose
    // every write takes 5 ms (the fake plugin's slow_write), so that it is
    // still in its trial when killed: a simulated trial lasts milliseconds,
    // and a wall-clock one can be ended first by the watchdog on a loaded
    // machine, which would make another history than the one-file run's.
    std::vector<std::string> killed = run_args(db_a, "A1", "virtual");
    for (const char* arg : {"--device", "", "--device-option", "fault=slow_write"}) killed.emplace_back(arg);
    killed[killed.size() - 3] = "plugin-inprocess:" + kFake;
    testing::ChildProcess a(killed, (dir_.path() / (tag + "_a.log")).string());
    testing::ChildProcess b(run_args(db_b, "B1", "virtual"), (dir_.path() / (tag + "_b.log")).string());
    const bool running = testing::wait_until(
        [&] {
          try {
            db::OpenOptions open;
            open.recover = false;
            open.read_only = true;
            open.integrity = db::OpenOptions::Integrity::kSkip;
            db::StudyDb db(db_a, open);
            for (const db::TrialRow& t : db.trials())
              if (t.participant_code == "A1" && t.status == db::TrialStatus::kRunning && db.sample_count(t.id, 0) > 0)
                return true;
          } catch (const db::DbError&) {
          }
          return false;
        },
        std::chrono::seconds(20));
    ASSERT_TRUE(running) << a.output();
    a.kill(SIGKILL);
    EXPECT_EQ(a.wait(), -SIGKILL);
    EXPECT_EQ(b.wait(), 0) << b.output();
    const auto [rc, out] = testing::run_cli(kBinary, "session run --db " + db_a + " --participant A1 --clock virtual "
                                                     "--rate-hz 150");
    ASSERT_EQ(rc, 0) << out;
    EXPECT_THAT(out, HasSubstr("1 re-queued"));
  }

  std::pair<int, std::string> merge(const std::string& args) const {
    return testing::run_cli(kBinary, "study merge " + args);
  }

  // metrics.csv without the column named `drop`.
  static std::string without_column(const std::string& csv, const std::string& drop) {
    std::istringstream in(csv);
    std::string line, out;
    int skip = -1;
    while (std::getline(in, line)) {
      std::vector<std::string> fields;
      std::string f;
      std::istringstream l(line);
      while (std::getline(l, f, ',')) fields.push_back(f);
      if (!line.empty() && line.back() == ',') fields.push_back("");
      if (skip < 0 && out.empty())
        for (std::size_t i = 0; i < fields.size(); ++i)
          if (fields[i] == drop) skip = static_cast<int>(i);
      for (std::size_t i = 0; i < fields.size(); ++i)
        if (static_cast<int>(i) != skip) out += fields[i] + (i + 1 < fields.size() ? "," : "");
      out += "\n";
    }
    return out;
  }

  std::string analyze(const std::string& db, const std::string& out) const {
    const auto [rc, text] = testing::run_cli(kBinary, "analyze --db " + db + " --out " + (dir_.path() / out).string() +
                                                          " --no-plots --no-ks --quiet");
    EXPECT_EQ(rc, 0) << text;
    return text;
  }

  testing::ScratchDir dir_;
  fs::path protocol_;
};

TEST_F(StudyMergeTest, TwoSitesOneKilledAndResumedMergeToWhatOneFileHolds) {
  const std::string a = create("site_a.db", protocol_), b = create("site_b.db", protocol_);
  const std::string one = create("one.db", protocol_);
  run_sites(a, b, "sites");
  run_sites(one, one, "one");
  const std::string all = (dir_.path() / "all.db").string();
  const std::string a_bytes = testing::slurp(a), b_bytes = testing::slurp(b);

  auto [rc, out] = merge(a + " " + b + " --site " + b + "=Basel --out " + all);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("site 'site_a', 1 participant(s) with sessions, 2 session(s)"),
                         HasSubstr("site 'Basel', 1 participant(s) with sessions, 1 session(s)"),
                         HasSubstr("2 participants, 3 sessions, 9 trials")));
  EXPECT_EQ(testing::slurp(a), a_bytes) << "an input was written";
  EXPECT_EQ(testing::slurp(b), b_bytes) << "an input was written";

  // An ordinary study to every reader.
  std::tie(rc, out) = testing::run_cli(kBinary, "study check --db " + all);
  EXPECT_EQ(rc, 0) << out;
  EXPECT_THAT(out, HasSubstr("no damage found"));
  std::tie(rc, out) = testing::run_cli(kBinary, "export --db " + all + " --format csv --out " + (dir_.path() / "x").string());
  EXPECT_EQ(rc, 0) << out;
  std::tie(rc, out) = testing::run_cli(
      kBinary, "sim replay --db " + all + " --trial 9 --out " + (dir_.path() / "replay.csv").string());
  EXPECT_EQ(rc, 0) << out;
  std::tie(rc, out) = testing::run_shell(std::string(HAPTICLAB_PYTHON) + " -c 'import sys; sys.path.insert(0, \"" +
                                         HAPTICLAB_SOURCE_DIR + "/python\"); import hapticlab_db as h; "
                                         "s = h.StudyDatabase(sys.argv[1]); print(\"rows\", len(s.samples(9)))' " + all +
                                         " 2>&1");
  EXPECT_EQ(rc, 0) << out;
  EXPECT_THAT(out, HasSubstr("rows "));
  std::tie(rc, out) = testing::run_shell(std::string(HAPTICLAB_SQLITE3_CLI) + " -cmd '.load " +
                                         HAPTICLAB_SQLITE_EXTENSION + "' " + all +
                                         " 'SELECT count(*) > 0 FROM samples(9)' 2>&1");
  EXPECT_EQ(rc, 0) << out;
  EXPECT_EQ(out, "1\n");

  // The merged analysis is the one-file analysis, with each participant's site.
  const std::string said = analyze(all, "merged");
  analyze(one, "one");
  const std::string merged_csv = testing::slurp(dir_.path() / "merged" / "metrics.csv");
  const std::string one_csv = testing::slurp(dir_.path() / "one" / "metrics.csv");
  EXPECT_THAT(merged_csv, AllOf(HasSubstr("trial_id,participant,site,task"), HasSubstr(",A1,site_a,clip,"),
                                HasSubstr(",B1,Basel,clip,")));
  EXPECT_THAT(one_csv, Not(HasSubstr(",site,")));
  EXPECT_EQ(without_column(merged_csv, "site"), without_column(one_csv, "site"));
  EXPECT_THAT(said, HasSubstr("clip: sites balanced"));
  EXPECT_THAT(testing::slurp(dir_.path() / "merged" / "report.md"),
              AllOf(HasSubstr("## Sites"), HasSubstr("| Basel | B1 |"), HasSubstr("| site\\_a | A1 |")));

  // Merging again, or with an input named twice: nothing changes.
  struct stat before {};
  ASSERT_EQ(::stat(all.c_str(), &before), 0);
  const std::string all_bytes = testing::slurp(all);
  std::tie(rc, out) = merge(a + " " + b + " " + a + " --site " + b + "=Basel --out " + all);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_THAT(out, AllOf(HasSubstr(a + ": the same file as an earlier input; read once"), HasSubstr("unchanged")));
  struct stat after {};
  ASSERT_EQ(::stat(all.c_str(), &after), 0);
  EXPECT_EQ(after.st_ino, before.st_ino) << "--out was rewritten";
  EXPECT_EQ(testing::slurp(all), all_bytes);
  // Into a new file, an input named twice counts once (it said 3).
  std::tie(rc, out) = merge(a + " " + b + " " + a + " --site " + b + "=Basel --out " +
                            (dir_.path() / "named_twice.db").string());
  ASSERT_EQ(rc, 0) << out;
  EXPECT_THAT(out, HasSubstr("merged 2 site file(s) into "));
  // A copy of a site's file beside it: the same sessions, taken once.
  fs::copy_file(a, dir_.path() / "copy_of_a.db");
  std::tie(rc, out) = merge(a + " " + (dir_.path() / "copy_of_a.db").string() + " " + b + " --site " + b +
                            "=Basel --out " + all);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("participant 'A1': the same 2 session(s)"), HasSubstr("unchanged")));
}

// Bad input (§5): each refused, naming the file, the row and the rule, and
// nothing written to --out.
TEST_F(StudyMergeTest, BadSiteFilesAreRefusedByName) {
  const std::string a = create("a.db", protocol_), b = create("b.db", protocol_);
  for (const auto& [db, who] : {std::pair{a, "A1"}, std::pair{b, "B1"}}) {
    const auto [rc, out] = testing::run_cli(kBinary, "session run --db " + db + " --participant " + who +
                                                         " --clock virtual --rate-hz 150 --max-trials 2");
    ASSERT_EQ(rc, 0) << out;
  }
  const std::string out_db = (dir_.path() / "all.db").string();
  const auto refused = [&](const std::string& args, const std::vector<std::string>& said) {
    const auto [rc, text] = merge(args);
    EXPECT_EQ(rc, 1) << args << "\n" << text;
    for (const std::string& s : said) EXPECT_THAT(text, HasSubstr(s)) << args;
    EXPECT_FALSE(fs::exists(out_db)) << args;
    for (const auto& f : fs::directory_iterator(dir_.path()))
      EXPECT_THAT(f.path().filename().string(), Not(HasSubstr(".merge-"))) << "a temporary file was left";
  };
  // Another protocol.
  const std::string other = create("other.db", write_protocol("other.json", "another study"));
  refused(a + " " + other + " --out " + out_db,
          {"different protocols", a, other, "study 'another study'", "protocol SHA-256"});
  // Onto one of its inputs.
  const std::string a_bytes = testing::slurp(a);
  {
    const auto [rc, text] = merge(a + " " + b + " --out " + a);
    EXPECT_EQ(rc, 1);
    EXPECT_THAT(text, HasSubstr("--out '" + a + "' is the input '" + a + "' (the same file)"));
    EXPECT_EQ(testing::slurp(a), a_bytes);
  }
  // A participant with sessions in two files.
  const std::string c = create("c.db", protocol_);
  {
    const auto [rc, text] = testing::run_cli(kBinary, "session run --db " + c +
                                                          " --participant A1 --clock virtual --rate-hz 150 --max-trials 1");
    ASSERT_EQ(rc, 0) << text;
  }
  refused(a + " " + b + " " + c + " --out " + out_db,
          {"participant 'A1' has sessions in two files: " + a + " (1) and " + c + " (1)", "one site's file"});
  // A file named like a site an earlier merge already holds: one station or
  // two under one name (the merge took them as one, silently).
  const std::string earlier = (dir_.path() / "earlier.db").string();
  ASSERT_EQ(merge(a + " --out " + earlier).first, 0);  // A1's sessions, site 'a'
  fs::create_directories(dir_.path() / "second");
  const std::string named_a = (dir_.path() / "second" / "a.db").string();
  fs::copy_file(b, named_a);  // B1's sessions, unstamped: its own, site 'a' by its name
  refused(earlier + " " + named_a + " --out " + out_db,
          {named_a + "'s own sessions would be site 'a' (its file's name), but " + earlier +
           " already holds sessions of site 'a' from an earlier merge", "--site " + named_a + "=a"});
  {
    const auto [rc, text] = merge(earlier + " " + named_a + " --site " + named_a + "=a --out " + out_db);
    EXPECT_EQ(rc, 0) << text;  // said to be one station
    fs::remove(out_db);
  }
  // One file named twice: the first name was dropped without a word.
  refused(a + " " + b + " --site " + b + "=A --site " + b + "=B --out " + out_db,
          {"--site: " + b + " is named twice ('" + b + "=A' and '" + b + "=B')"});
  // A re-merge that renames a site would lose the earlier name's sessions;
  // it was blamed on a missing input file.
  {
    const std::string re = (dir_.path() / "re.db").string();
    ASSERT_EQ(merge(a + " " + b + " --out " + re).first, 0);  // b's sessions: site 'b'
    const std::string before = testing::slurp(re);
    const auto [rc, text] = merge(a + " " + b + " --site " + b + "=Basel --out " + re);
    EXPECT_EQ(rc, 1) << text;
    EXPECT_THAT(text, HasSubstr("session(s) of site 'b', which the inputs hold as site 'Basel')"));
    EXPECT_THAT(text, HasSubstr("a site renamed? --out calls it 'b', the inputs 'Basel': keep the earlier name "
                                "(--site FILE=b) or give a new --out"));
    EXPECT_EQ(testing::slurp(re), before);
  }
  // A site name with '=' in it is the name's (it was split at the last '=').
  {
    const auto [rc, text] = merge(a + " " + b + " --site " + b + "=x=y --out " + out_db);
    EXPECT_EQ(rc, 0) << text;
    EXPECT_THAT(text, HasSubstr("site 'x=y'"));
    fs::remove(out_db);
  }
  // A damaged chunk: named with its trial, instrument and ticks.
  fs::copy_file(b, dir_.path() / "damaged.db");
  const std::string damaged = (dir_.path() / "damaged.db").string();
  // Byte 21 changed to another value whatever it was (a fixed value is
  // no damage where the byte already has it).
  testing::edit_with_sqlite(damaged,
                            "UPDATE sample_chunk SET data = CAST(substr(data, 1, 20) || "
                            "CASE WHEN substr(data, 21, 1) = x'00' THEN x'01' ELSE x'00' END || substr(data, 22) AS BLOB) "
                            "WHERE id = (SELECT min(id) FROM sample_chunk)");
  refused(a + " " + damaged + " --out " + out_db,
          {damaged + ": damaged sample chunk: trial ", "instrument", "ticks", "checksum mismatch", "study check"});
  // A file from a newer HapticLab.
  fs::copy_file(b, dir_.path() / "newer.db");
  const std::string newer = (dir_.path() / "newer.db").string();
  testing::edit_with_sqlite(newer, "PRAGMA user_version = 99");
  refused(a + " " + newer + " --out " + out_db, {newer, "schema version 99", "newer than this HapticLab supports"});
  // A file of schema 8 (before sites) merges as it is, unchanged.
  fs::copy_file(b, dir_.path() / "v8.db");
  const std::string v8 = (dir_.path() / "v8.db").string();
  // Genuinely of version 8: no site, no loop rate, no participant model
  // (a merge read the last two as if every file had them: an SQL error).
  testing::edit_with_sqlite(v8, "ALTER TABLE session DROP COLUMN site; ALTER TABLE session DROP COLUMN rate_Hz; "
                                "ALTER TABLE session DROP COLUMN participant_model; "
                                "ALTER TABLE setting DROP COLUMN parameters_sha256; PRAGMA user_version = 8");
  const std::string v8_bytes = testing::slurp(v8);
  {
    const auto [rc, text] = merge(a + " " + v8 + " --out " + out_db);
    EXPECT_EQ(rc, 0) << text;
    EXPECT_THAT(text, HasSubstr("v8.db: site 'v8', 1 participant(s) with sessions, 1 session(s)"));
    EXPECT_EQ(testing::slurp(v8), v8_bytes);
    fs::remove(out_db);
  }
  // An older file's values are checked as a current one's: a text 'nan'
  // event time was copied as 0.0 and the merged file then passed every check.
  fs::copy_file(b, dir_.path() / "v9nan.db");
  const std::string v9nan = (dir_.path() / "v9nan.db").string();
  testing::edit_with_sqlite(v9nan, "ALTER TABLE session DROP COLUMN rate_Hz; ALTER TABLE session DROP COLUMN "
                                   "participant_model; ALTER TABLE setting DROP COLUMN parameters_sha256; UPDATE event SET t_s = 'nan' WHERE id = (SELECT min(id) FROM "
                                   "event); PRAGMA user_version = 9");
  refused(a + " " + v9nan + " --out " + out_db, {v9nan + ": damaged site file", "t_s is text 'nan', expected a REAL"});
  // A setting edited at a site: its sessions ran with parameters the study
  // did not define (one space more is another text, whatever a parser says).
  fs::copy_file(b, dir_.path() / "edited.db");
  const std::string edited = (dir_.path() / "edited.db").string();
  testing::edit_with_sqlite(edited, "UPDATE setting SET parameters_json = parameters_json || ' ' WHERE id = 2");
  refused(a + " " + edited + " --out " + out_db,
          {edited + ": setting '", "(id 2): its parameters_json does not match the SHA-256 stored with it"});
  // A session still open at a site (running, or killed and not recovered).
  fs::copy_file(b, dir_.path() / "open.db");
  const std::string open = (dir_.path() / "open.db").string();
  testing::edit_with_sqlite(open, "UPDATE session SET status = 'open'");
  refused(a + " " + open + " --out " + out_db, {open + ": participant 'B1' has session 1 still open"});
  // --out a site's own file (sessions recorded in it): never overwritten.
  const std::string c_bytes = testing::slurp(c);
  {
    const auto [rc, text] = merge(a + " " + b + " --out " + c);
    EXPECT_EQ(rc, 1);
    EXPECT_THAT(text, HasSubstr("it is a site's own file, not an earlier merge"));
    EXPECT_EQ(testing::slurp(c), c_bytes);
  }
  // A previous merge holding a site the inputs lack: not overwritten.
  {
    auto [rc, text] = merge(a + " " + b + " --out " + out_db);
    ASSERT_EQ(rc, 0) << text;
    const std::string merged = testing::slurp(out_db);
    std::tie(rc, text) = merge(a + " --out " + out_db);
    EXPECT_EQ(rc, 1);
    EXPECT_THAT(text, HasSubstr("participant 'B1' (1 session(s) of site 'b')"));
    EXPECT_EQ(testing::slurp(out_db), merged);
    fs::remove(out_db);
  }
}

// A trial added at two sites (a re-queued copy, here made through the
// library) gets the same id in both files: the second keeps its samples
// under a new id, each chunk verified under the old id and re-checksummed.
TEST_F(StudyMergeTest, ATrialRenumberedKeepsItsSamplesUnderItsNewId) {
  const std::string a = create("a.db", protocol_), b = create("b.db", protocol_);
  std::vector<db::StoredSample> samples(40);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    samples[i].tick = i;
    samples[i].t_s = 0.01 * static_cast<double>(i);
    samples[i].dt_s = 0.01;
    samples[i].value.raw_position[0] = 0.001 * static_cast<double>(i);
  }
  for (const auto& [path, who] : {std::pair{a, "A1"}, std::pair{b, "B1"}}) {
    db::StudyDb db(path);
    const std::int64_t pid = *db.find_participant(1, who);
    const std::int64_t session = db.begin_session(pid, "sim", "virtual", 1000.0);
    const std::int64_t trial = db.add_trial({pid, "clip", 1, 3, 1, 5});
    ASSERT_EQ(trial, 9);
    db.start_trial(trial, session);
    db.insert_chunk(trial, 1, samples);
    db.end_trial(trial, db::TrialStatus::kComplete);
    db.end_session(session);
  }
  const std::string all = (dir_.path() / "all.db").string();
  // What a merge killed mid-way left (its process gone): removed by the next.
  const fs::path stale = dir_.path() / ".all.db.merge-2147483646.tmp";
  std::ofstream(stale) << "half a merge";
  auto [rc, out] = merge(a + " " + b + " --out " + all);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_THAT(out, HasSubstr("b.db: site 'b', 1 participant(s) with sessions, 1 session(s), 1 trial(s) renumbered"));
  EXPECT_FALSE(fs::exists(stale)) << "a dead merge's temporary file was left";
  std::tie(rc, out) = testing::run_cli(kBinary, "study check --db " + all);
  EXPECT_EQ(rc, 0) << out;
  db::OpenOptions open;
  open.read_only = true;
  db::StudyDb merged(all, open);
  EXPECT_EQ(merged.trial(9).participant_code, "A1");
  EXPECT_EQ(merged.trial(10).participant_code, "B1");
  const std::vector<db::StoredSample> back = merged.samples(10, 1);
  ASSERT_EQ(back.size(), samples.size());
  EXPECT_EQ(back.back().t_s, samples.back().t_s);
  EXPECT_EQ(merged.session(2).site, "b");
}

// A full disk while writing the merge: stopped with a clear message, no
// --out and no temporary file left, the inputs untouched; an earlier merge
// at --out stays as it was.
TEST_F(StudyMergeTest, AFullDiskStopsTheMergeAndLeavesNoPartialOut) {
  if (std::system("unshare -m sh -c 'mount -t tmpfs -o size=64k tmpfs /mnt' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "mounting a tmpfs needs root in a mount namespace";
  const std::string a = create("a.db", protocol_), b = create("b.db", protocol_);
  for (const auto& [db, who] : {std::pair{a, "A1"}, std::pair{b, "B1"}}) {
    const auto [rc, out] =
        testing::run_cli(kBinary, "session run --db " + db + " --participant " + who + " --clock virtual --rate-hz 150");
    ASSERT_EQ(rc, 0) << out;
  }
  // The earlier merge: site a alone (participant B1 planned only), small.
  const std::string earlier = (dir_.path() / "earlier.db").string();
  {
    const auto [rc, out] = merge(a + " --out " + earlier);
    ASSERT_EQ(rc, 0) << out;
  }
  const std::string a_bytes = testing::slurp(a), b_bytes = testing::slurp(b), earlier_bytes = testing::slurp(earlier);
  const fs::path mnt = dir_.path() / "mnt";
  fs::create_directories(mnt);
  // Room for the earlier merge and a little more, not for both sites.
  const std::uintmax_t size_kB = fs::file_size(earlier) / 1024 + 256;
  const std::string kept = (dir_.path() / "kept").string();
  const std::string script =
      "mount -t tmpfs -o size=" + std::to_string(size_kB) + "k tmpfs " + mnt.string() + " && cp " + earlier + " " +
      mnt.string() + "/all.db && " + kBinary + " study merge " + a + " " + b + " --out " + mnt.string() +
      "/none.db; rc1=$?; " + kBinary + " study merge " + a + " " + b + " --out " + mnt.string() +
      "/all.db; rc2=$?; mkdir -p " + kept + " && cp -r " + mnt.string() + "/. " + kept + "/; exit $((rc1 * 10 + rc2))";
  const auto [status, out] = testing::run_cli("unshare", "-m sh -c '" + script + "'");
  EXPECT_EQ(status, 11) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("study merge stopped"), HasSubstr("the disk is full"),
                         HasSubstr("was not created and the inputs are untouched"), HasSubstr("is as it was"),
                         HasSubstr("run the same merge again")));
  EXPECT_FALSE(fs::exists(fs::path(kept) / "none.db")) << "a partial --out was left";
  for (const auto& f : fs::directory_iterator(kept))
    EXPECT_THAT(f.path().filename().string(), Not(HasSubstr(".merge-"))) << "a temporary file was left";
  EXPECT_EQ(testing::slurp(fs::path(kept) / "all.db"), earlier_bytes) << "the earlier merge was changed";
  EXPECT_EQ(testing::slurp(a), a_bytes);
  EXPECT_EQ(testing::slurp(b), b_bytes);
}

}  // namespace
}  // namespace hapticlab
