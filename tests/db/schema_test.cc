#include "db/schema.h"

#include <filesystem>
#include <algorithm>
#include <fstream>
#include <span>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db/chunk_reader.h"
#include "db/sample_codec.h"
#include "core/common/sha256.h"
#include "db/study_db.h"
#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

std::vector<std::string> tables(Database& db) {
  std::vector<std::string> out;
  Statement s = db.prepare("SELECT name FROM sqlite_schema WHERE type = 'table' ORDER BY name");
  while (s.step()) out.push_back(s.column_text(0));
  return out;
}

// Every table and index as SQLite stores its definition, whitespace removed.
std::vector<std::string> schema_sql(Database& db) {
  std::vector<std::string> out;
  Statement s = db.prepare("SELECT type, name, coalesce(sql, '') FROM sqlite_schema ORDER BY type, name");
  while (s.step()) {
    // Without whitespace: the hand-made version 1 is laid out differently.
    std::string sql = s.column_text(2);
    std::erase_if(sql, [](char c) { return c == ' ' || c == '\n' || c == '\t'; });
    out.push_back(s.column_text(0) + " " + s.column_text(1) + ": " + sql);
  }
  return out;
}

std::vector<std::string> columns(Database& db, const std::string& table) {
  std::vector<std::string> out;
  Statement s = db.prepare("SELECT name, type, \"notnull\" FROM pragma_table_info(?1) ORDER BY cid");
  s.bind(1, table);
  while (s.step()) out.push_back(s.column_text(0) + " " + s.column_text(1) + (s.column_int64(2) ? " NOT NULL" : ""));
  return out;
}

TEST(Schema, FreshDatabaseIsAtTheCurrentVersionWithEveryTable) {
  testing::TempDir dir;
  StudyDb db(dir.file("fresh.db"));
  EXPECT_EQ(db.schema_version_found(), 0);
  EXPECT_EQ(db.connection().pragma_int("user_version"), kSchemaVersion);
  EXPECT_EQ(db.connection().pragma_int("application_id"), kApplicationId);
  EXPECT_EQ(tables(db.connection()),
            (std::vector<std::string>{"device_counter", "event", "loop_timing", "operator_action", "participant", "sample_chunk",
                                      "session", "setting", "study", "training", "trial"}));
  Statement s = db.connection().prepare("PRAGMA journal_mode");
  ASSERT_TRUE(s.step());
  EXPECT_EQ(s.column_text(0), "wal");
}

TEST(Schema, MigrationStepsAreNumberedInOrder) {
  ASSERT_EQ(migrations().size(), static_cast<std::size_t>(kSchemaVersion));
  for (std::size_t i = 0; i < migrations().size(); ++i) EXPECT_EQ(migrations()[i].to_version, static_cast<int>(i + 1));
}

TEST(Schema, ReopeningDoesNotMigrateAgain) {
  testing::TempDir dir;
  { StudyDb db(dir.file("a.db")); }
  StudyDb db(dir.file("a.db"));
  EXPECT_EQ(db.schema_version_found(), kSchemaVersion);
}

TEST(Schema, NewerVersionIsRefusedNamingTheVersions) {
  testing::TempDir dir;
  const auto path = dir.file("future.db");
  const std::string future = std::to_string(kSchemaVersion + 1);
  { StudyDb db(path); db.connection().exec("PRAGMA user_version = " + future); }
  for (const bool read_only : {false, true}) {
    OpenOptions options;
    options.read_only = read_only;
    try {
      StudyDb db(path, options);
      FAIL() << "opened a version " << future << " database";
    } catch (const DbError& e) {
      EXPECT_THAT(e.what(), AllOf(HasSubstr(path.string()), HasSubstr("version " + future), HasSubstr("newer"),
                                  HasSubstr("supports (" + std::to_string(kSchemaVersion) + ")")));
    }
  }
  // Refused without a change: the file still says what it said.
  Database raw(path);
  EXPECT_EQ(raw.pragma_int("user_version"), kSchemaVersion + 1);
}

TEST(Schema, NonSqliteFileIsRefusedNamingTheFile) {
  testing::TempDir dir;
  const auto path = dir.file("notes.db");
  const std::string text = "participant,force_N\nP01,1.5\n" + std::string(2000, 'x');
  std::ofstream(path, std::ios::binary) << text;
  for (const bool read_only : {false, true}) {
    OpenOptions options;
    options.read_only = read_only;
    try {
      StudyDb db(path, options);
      FAIL() << "opened a CSV file as a study database";
    } catch (const DbError& e) {
      EXPECT_THAT(e.what(), AllOf(HasSubstr(path.string()), HasSubstr("not an SQLite database")));
    }
  }
  // ... and left it alone.
  EXPECT_EQ(std::filesystem::file_size(path), text.size());
}

TEST(Schema, ForeignDatabaseIsRefused) {
  testing::TempDir dir;
  const auto path = dir.file("other.db");
  { Database db(path); db.exec("CREATE TABLE accounts (id INTEGER)"); }
  EXPECT_THROW(StudyDb db(path), DbError);
  { Database db(path); db.exec("PRAGMA user_version = 1"); }
  try {
    StudyDb db(path);
    FAIL();
  } catch (const DbError& e) {
    EXPECT_THAT(e.what(), HasSubstr("not a HapticLab study database"));
  }
}

// The version 1 layout as it was shipped, written out by hand (not taken
// from schema.cc, so a change there cannot silently change this test).
constexpr const char* kHandMadeV1 = R"sql(
CREATE TABLE study (id INTEGER PRIMARY KEY, name TEXT NOT NULL UNIQUE, protocol_json TEXT NOT NULL,
  protocol_sha256 TEXT NOT NULL CHECK (length(protocol_sha256) = 64), seed TEXT NOT NULL,
  software_version TEXT NOT NULL, created_utc TEXT NOT NULL);
CREATE TABLE participant (id INTEGER PRIMARY KEY, study_id INTEGER NOT NULL REFERENCES study (id),
  code TEXT NOT NULL, UNIQUE (study_id, code));
CREATE TABLE setting (id INTEGER PRIMARY KEY, study_id INTEGER NOT NULL REFERENCES study (id),
  name TEXT NOT NULL, parameters_json TEXT NOT NULL, UNIQUE (study_id, name));
CREATE TABLE session (id INTEGER PRIMARY KEY, participant_id INTEGER NOT NULL REFERENCES participant (id),
  started_unix_s REAL NOT NULL, ended_unix_s REAL, device TEXT NOT NULL,
  clock TEXT NOT NULL CHECK (clock IN ('virtual', 'wall')),
  status TEXT NOT NULL CHECK (status IN ('open', 'closed', 'interrupted')));
CREATE TABLE trial (id INTEGER PRIMARY KEY, participant_id INTEGER NOT NULL REFERENCES participant (id),
  task TEXT NOT NULL, setting_id INTEGER NOT NULL REFERENCES setting (id), repetition INTEGER NOT NULL,
  block INTEGER NOT NULL, position INTEGER NOT NULL,
  status TEXT NOT NULL DEFAULT 'planned' CHECK (status IN ('planned', 'running', 'complete', 'aborted')),
  session_id INTEGER REFERENCES session (id), started_unix_s REAL, ended_unix_s REAL, abort_reason TEXT,
  dropped_samples INTEGER NOT NULL DEFAULT 0, UNIQUE (participant_id, position));
CREATE TABLE sample_chunk (id INTEGER PRIMARY KEY, trial_id INTEGER NOT NULL REFERENCES trial (id),
  instrument INTEGER NOT NULL CHECK (instrument IN (0, 1)), first_tick INTEGER NOT NULL,
  count INTEGER NOT NULL CHECK (count > 0), t0_s REAL NOT NULL, data BLOB NOT NULL,
  UNIQUE (trial_id, instrument, first_tick));
CREATE TABLE event (id INTEGER PRIMARY KEY, trial_id INTEGER NOT NULL REFERENCES trial (id), t_s REAL NOT NULL,
  type TEXT NOT NULL, instrument INTEGER NOT NULL CHECK (instrument IN (-1, 0, 1)),
  item_index INTEGER NOT NULL DEFAULT 0, detail TEXT);
CREATE INDEX event_by_trial ON event (trial_id, t_s);
PRAGMA user_version = 1;
PRAGMA application_id = 1212956994;
)sql";

std::vector<StoredSample> some_samples() {
  std::vector<StoredSample> out;
  for (std::uint64_t t = 10; t < 60; ++t) {
    const LoopSample s = testing::make_sample(t);
    out.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[0]});
  }
  return out;
}

void fill_v1(Database& db) {
  db.exec(kHandMadeV1);
  db.prepare("INSERT INTO study VALUES (1, 'old study', '{\"study\":\"old\"}', ?1, '18446744073709551615', '0.0.9', "
             "'2023-01-02T03:04:05.000Z')")
      .bind(1, sha256_hex("{\"study\":\"old\"}"))
      .run();
  db.exec(R"sql(
    INSERT INTO participant VALUES (1, 1, 'S1');
    INSERT INTO setting VALUES (1, 1, 'Friction', '{"name":"Friction"}');
    INSERT INTO session VALUES (1, 1, 1.7e9, 1.7e9 + 600, 'sim', 'virtual', 'closed');
    INSERT INTO trial VALUES (1, 1, 'dissection', 1, 1, 1, 1, 'complete', 1, 1.7e9 + 10, 1.7e9 + 70, NULL, 3);
    INSERT INTO trial VALUES (2, 1, 'dissection', 1, 2, 2, 2, 'planned', NULL, NULL, NULL, NULL, 0);
    INSERT INTO event VALUES (1, 1, 0.25, 'contact_start', 0, 0, NULL);
  )sql");
  const std::vector<StoredSample> samples = some_samples();
  const std::vector<std::byte> blob = testing::legacy_blob(samples);
  db.prepare("INSERT INTO sample_chunk VALUES (1, 1, 0, 10, 50, ?1, ?2)").bind(1, samples[0].t_s).bind_blob(2, blob).run();
}

TEST(Schema, MigratesAVersion1DatabaseKeepingItsData) {
  testing::TempDir dir;
  const auto path = dir.file("v1.db");
  { Database db(path); fill_v1(db); }

  StudyDb db(path);
  EXPECT_EQ(db.schema_version_found(), 1);
  EXPECT_EQ(db.connection().pragma_int("user_version"), kSchemaVersion);

  // The data survived.
  const StudyRow study = db.study(1);
  EXPECT_EQ(study.name, "old study");
  EXPECT_EQ(study.seed, 18446744073709551615ull);
  EXPECT_EQ(study.protocol_sha256, sha256_hex(study.protocol_json));
  const TrialRow t1 = db.trial(1);
  EXPECT_EQ(t1.status, TrialStatus::kComplete);
  EXPECT_EQ(t1.participant_code, "S1");
  EXPECT_EQ(t1.setting_name, "Friction");
  // Version 11 gave the setting the digest of its text, which every read compares.
  EXPECT_EQ(db.setting_json(1), "{\"name\":\"Friction\"}");
  {
    Statement digest = db.connection().prepare("SELECT parameters_sha256 FROM setting WHERE id = 1");
    ASSERT_TRUE(digest.step());
    EXPECT_EQ(digest.column_text(0), sha256_hex("{\"name\":\"Friction\"}"));
  }
  EXPECT_EQ(db.trial(2).status, TrialStatus::kPlanned);
  const std::vector<StoredSample> stored = db.samples(1, 0);
  ASSERT_EQ(stored.size(), 50u);
  EXPECT_EQ(stored.front().tick, 10u);
  EXPECT_EQ(stored.back().t_s, some_samples().back().t_s);
  ASSERT_EQ(db.events(1).size(), 1u);
  EXPECT_EQ(db.events(1)[0].type, "contact_start");

  // The drop count moved from trial to loop_timing; timing was not measured.
  const std::optional<LoopTimingRow> timing = db.loop_timing(1);
  ASSERT_TRUE(timing.has_value());
  EXPECT_EQ(timing->dropped_samples, 3u);
  EXPECT_FALSE(timing->timing.has_value());
  EXPECT_FALSE(db.loop_timing(2).has_value());  // planned: nothing to say yet
  for (const std::string& c : columns(db.connection(), "trial")) EXPECT_THAT(c, ::testing::Not(HasSubstr("dropped")));

  // The new tables exist and work.
  TrainingRow training;
  training.session_id = 1;
  training.task = "clip";
  training.started_unix_s = 1.7e9;
  training.trials = 2;
  db.add_training(training);
  EXPECT_EQ(db.training(1).size(), 1u);

  // And the migrated layout is exactly the fresh one, indexes included.
  StudyDb fresh(dir.file("fresh.db"));
  for (const std::string& table : tables(fresh.connection()))
    EXPECT_EQ(columns(db.connection(), table), columns(fresh.connection(), table)) << table;
  EXPECT_EQ(schema_sql(db.connection()), schema_sql(fresh.connection()));
  EXPECT_EQ(db.connection().pragma_int("foreign_keys"), 1) << "migration turns foreign keys back on";
}

// Version 2 built by running only migrations 1 and 2 (as a version 2
// HapticLab did), holding an aborted trial and the data hanging off it.
TEST(Schema, MigratesAVersion2DatabaseAndAllowsRequeueingAbortedTrials) {
  testing::TempDir dir;
  const auto path = dir.file("v2.db");
  std::vector<StoredSample> samples = some_samples();
  {
    Database db(path);
    for (const Migration& m : migrations().first(2)) db.exec(m.sql);
    db.exec("PRAGMA user_version = 2; PRAGMA application_id = 1212956994;");
    db.exec(R"sql(
      INSERT INTO study VALUES (1, 's', '{}', ')sql" + sha256_hex("{}") + R"sql(', '5', '0.1.0', '2024-01-01T00:00:00.000Z');
      INSERT INTO participant VALUES (1, 1, 'P01');
      INSERT INTO setting VALUES (1, 1, 'No FFB', '{}');
      INSERT INTO session VALUES (1, 1, 1.7e9, NULL, 'sim', 'wall', 'interrupted');
      INSERT INTO trial VALUES (1, 1, 'clip', 1, 1, 1, 1, 'complete', 1, 1.7e9, 1.7e9 + 60, NULL);
      INSERT INTO trial VALUES (2, 1, 'clip', 1, 2, 1, 2, 'aborted', 1, 1.7e9 + 61, NULL, 'operator abort');
      INSERT INTO trial VALUES (3, 1, 'clip', 1, 3, 1, 3, 'planned', NULL, NULL, NULL, NULL);
      INSERT INTO loop_timing (trial_id, count, p99_period_s, dropped_samples) VALUES (2, 900, 0.00105, 4);
      INSERT INTO event VALUES (1, 2, 0.5, 'contact_start', 1, 0, NULL);
    )sql");
    db.prepare("INSERT INTO sample_chunk VALUES (1, 2, 1, 10, 50, ?1, ?2)")
        .bind(1, samples[0].t_s).bind_blob(2, testing::legacy_blob(samples)).run();
    // Version 2 could not hold the re-queued copy at the aborted trial's position.
    EXPECT_THROW(db.exec("INSERT INTO trial (participant_id, task, setting_id, repetition, block, position) "
                         "VALUES (1, 'clip', 1, 2, 1, 2)"),
                 DbError);
  }

  StudyDb db(path);
  EXPECT_EQ(db.schema_version_found(), 2);
  EXPECT_EQ(db.connection().pragma_int("user_version"), kSchemaVersion);
  // Rows, references and ids survived the rebuild of trial.
  EXPECT_EQ(db.trial(1).status, TrialStatus::kComplete);
  EXPECT_EQ(db.trial(2).abort_reason, "operator abort");
  EXPECT_EQ(db.trial(2).setting_name, "No FFB");
  ASSERT_EQ(db.samples(2, 1).size(), samples.size());
  EXPECT_EQ(db.samples(2, 1).back().t_s, samples.back().t_s);
  EXPECT_EQ(db.events(2).at(0).type, "contact_start");
  EXPECT_EQ(db.loop_timing(2)->timing->p99_period_s, 0.00105);
  EXPECT_EQ(db.loop_timing(2)->dropped_samples, 4u);
  Statement fk = db.connection().prepare("PRAGMA foreign_key_check");
  EXPECT_FALSE(fk.step()) << "a row points nowhere after the migration";

  // Now the aborted trial re-queues in place and runs before position 3.
  const std::int64_t copy = db.requeue_trial(2);
  EXPECT_EQ(db.trial(copy).position, 2);
  EXPECT_EQ(db.trial(copy).status, TrialStatus::kPlanned);
  EXPECT_EQ(db.next_planned_trial(1), copy);
  // Foreign keys are enforced again on this connection.
  EXPECT_THROW(db.connection().exec("INSERT INTO event (trial_id, t_s, type, instrument) VALUES (99, 0, 'x', -1)"),
               DbError);
}

// Version 3 (chunks without checksums) built by running migrations 1..3,
// with two old chunks. The migration checksums them as format 0: they read
// back unchanged, and damage done after it is caught.
TEST(Schema, MigratesAVersion3DatabaseChecksummingItsChunks) {
  testing::TempDir dir;
  const auto path = dir.file("v3.db");
  const std::vector<StoredSample> samples = some_samples();  // ticks 10..59
  const std::vector<std::byte> old_left = testing::legacy_blob(samples);
  {
    Database db(path);
    for (const Migration& m : migrations().first(3)) db.exec(m.sql);
    db.exec("PRAGMA user_version = 3; PRAGMA application_id = 1212956994;");
    db.exec(R"sql(
      INSERT INTO study VALUES (1, 's', '{}', ')sql" + sha256_hex("{}") + R"sql(', '5', '0.2.0', '2024-01-01T00:00:00.000Z');
      INSERT INTO participant VALUES (1, 1, 'P01');
      INSERT INTO setting VALUES (1, 1, 'No FFB', '{}');
      INSERT INTO session VALUES (1, 1, 1.7e9, 1.7e9 + 60, 'sim', 'virtual', 'closed');
      INSERT INTO trial VALUES (1, 1, 'clip', 1, 1, 1, 1, 'complete', 1, 1.7e9, 1.7e9 + 60, NULL);
    )sql");
    Statement insert = db.prepare("INSERT INTO sample_chunk VALUES (?1, 1, ?2, 10, 50, ?3, ?4)");
    insert.bind(1, std::int64_t{1}).bind(2, std::int64_t{0}).bind(3, samples[0].t_s).bind_blob(4, old_left).run();
    insert.reset();
    insert.bind(1, std::int64_t{2}).bind(2, std::int64_t{1}).bind(3, samples[0].t_s)
        .bind_blob(4, testing::legacy_blob(samples)).run();
  }

  {
    StudyDb db(path);
    EXPECT_EQ(db.schema_version_found(), 3);
    EXPECT_EQ(db.connection().pragma_int("user_version"), kSchemaVersion);
    Statement blob = db.connection().prepare("SELECT data FROM sample_chunk WHERE id = 1");
    ASSERT_TRUE(blob.step());
    const std::span<const std::byte> data = blob.column_blob(0);
    ASSERT_EQ(data.size(), old_left.size() + kChunkHeaderBytes);
    EXPECT_EQ(std::to_integer<int>(data[0]), kChunkFormatMigrated);
    EXPECT_TRUE(std::equal(old_left.begin(), old_left.end(), data.begin() + kChunkHeaderBytes))
        << "the old bytes are kept as they were";
    const std::vector<StoredSample> left = db.samples(1, 0);
    ASSERT_EQ(left.size(), samples.size());
    EXPECT_EQ(left.front().tick, 10u);
    EXPECT_EQ(left.back().t_s, samples.back().t_s);
    const ChunkCheck check = check_all_chunks(db.connection());
    EXPECT_EQ(check.chunks, 2u);
    EXPECT_EQ(check.migrated_chunks, 2u);
    EXPECT_TRUE(check.bad.empty());
  }
  // After the migration a flipped byte is caught.
  {
    Database db(path);
    testing::flip_chunk_byte(db, 2, 20);
    const ChunkCheck check = check_all_chunks(db);
    ASSERT_EQ(check.bad.size(), 1u);
    EXPECT_EQ(check.bad[0].trial_id, 1);
    EXPECT_EQ(check.bad[0].instrument, 1);
    EXPECT_EQ(check.bad[0].kind, ChunkError::Kind::kChecksum);
  }
}

// Version 6 (the previous HapticLab) built by running migrations 1..6, with
// chunks as it stored them (db_test_util.h schema6_blob: format 2 without a
// frame checksum, format 1, and a format 0 chunk from the version 4 step),
// plus one damaged then. The migration to 7 rewrites every chunk: the same
// samples, format 2 become 3, every checksum now covering trial and
// instrument; the damaged one stays as it was, and so stays damaged.
TEST(Schema, MigratesAVersion6DatabaseRewritingEveryChunk) {
  testing::TempDir dir;
  const auto path = dir.file("v6.db");
  const std::vector<StoredSample> samples = some_samples();  // ticks 10..59
  std::vector<std::byte> damaged = testing::schema6_blob(samples);
  damaged.back() ^= std::byte{0x40};
  {
    Database db(path);
    for (const Migration& m : migrations().first(6)) db.exec(m.sql);
    db.exec("PRAGMA user_version = 6; PRAGMA application_id = 1212956994;");
    db.exec(R"sql(
      INSERT INTO study VALUES (1, 's', '{}', ')sql" + sha256_hex("{}") + R"sql(', '5', '0.3.0', '2024-01-01T00:00:00.000Z');
      INSERT INTO participant VALUES (1, 1, 'P01');
      INSERT INTO setting VALUES (1, 1, 'No FFB', '{}');
      INSERT INTO session VALUES (1, 1, 1.7e9, 1.7e9 + 60, 'sim', 'virtual', 'closed');
      INSERT INTO trial VALUES (1, 1, 'clip', 1, 1, 1, 1, 'complete', 1, 1.7e9, 1.7e9 + 60, NULL);
      INSERT INTO trial VALUES (2, 1, 'clip', 1, 2, 1, 2, 'complete', 1, 1.7e9, 1.7e9 + 60, NULL);
    )sql");
    Statement insert = db.prepare("INSERT INTO sample_chunk VALUES (?1, ?2, ?3, 10, 50, ?4, ?5)");
    const auto add = [&](std::int64_t id, std::int64_t trial, std::int64_t instrument, std::span<const std::byte> blob) {
      insert.reset();
      insert.bind(1, id).bind(2, trial).bind(3, instrument).bind(4, samples[0].t_s).bind_blob(5, blob).run();
    };
    add(1, 1, 0, testing::schema6_blob(samples));
    add(2, 1, 1, testing::schema6_blob(samples, /*plain=*/true));
    add(3, 2, 0, checksum_legacy_chunk(10, 50, testing::legacy_blob(samples)));
    add(4, 2, 1, damaged);
  }
  StudyDb db(path);
  EXPECT_EQ(db.schema_version_found(), 6);
  EXPECT_EQ(db.connection().pragma_int("user_version"), kSchemaVersion);
  Statement formats = db.connection().prepare("SELECT id, hex(substr(data, 1, 1)), data FROM sample_chunk ORDER BY id");
  std::vector<std::string> got;
  while (formats.step()) got.push_back(formats.column_text(1));
  EXPECT_EQ(got, (std::vector<std::string>{"03", "01", "00", "02"}));
  for (const auto& [trial, instrument] : {std::pair{1, 0}, {1, 1}, {2, 0}}) {
    const std::vector<StoredSample> read = db.samples(trial, instrument);
    ASSERT_EQ(read.size(), samples.size());
    for (std::size_t i = 0; i < read.size(); ++i) {
      EXPECT_EQ(read[i].tick, samples[i].tick);
      EXPECT_EQ(read[i].t_s, samples[i].t_s);
      EXPECT_EQ(read[i].value.ve_force_N[1], static_cast<double>(to_stored_float(samples[i].value.ve_force_N[1])));
    }
  }
  ChunkCheck check = check_all_chunks(db.connection());
  EXPECT_EQ(check.chunks, 4u);
  EXPECT_EQ(check.migrated_chunks, 1u);
  ASSERT_EQ(check.bad.size(), 1u);
  EXPECT_EQ(check.bad[0].trial_id, 2);
  EXPECT_EQ(check.bad[0].instrument, 1);
  EXPECT_EQ(check.bad[0].kind, ChunkError::Kind::kChecksum);
  // From now on a chunk moved to the other trial is caught.
  db.connection().exec("DELETE FROM sample_chunk WHERE id = 4; UPDATE sample_chunk SET trial_id = 2 WHERE id = 2");
  check = check_all_chunks(db.connection());
  ASSERT_EQ(check.bad.size(), 1u);
  EXPECT_EQ(describe(check.bad[0]).substr(0, 57), "trial 2, right instrument (1), ticks 10..59: checksum mis");
}

// Version 8 (before multi-site merges) built by running migrations 1..8:
// its sessions stay readable, with no site (issue 36 §4).
TEST(Schema, MigratesAVersion8DatabaseGivingSessionsNoSite) {
  testing::TempDir dir;
  const auto path = dir.file("v8.db");
  {
    Database db(path);
    for (const Migration& m : migrations().first(8)) db.exec(m.sql);
    db.exec("PRAGMA user_version = 8; PRAGMA application_id = 1212956994;");
    db.exec(R"sql(
      INSERT INTO study VALUES (1, 's', '{}', ')sql" + sha256_hex("{}") + R"sql(', '5', '0.1.0', '2024-01-01T00:00:00.000Z');
      INSERT INTO participant VALUES (1, 1, 'P01');
      INSERT INTO session VALUES (1, 1, 1.7e9, 1.7e9 + 60, 'sim', 'virtual', 'closed');
    )sql");
  }
  StudyDb db(path);
  EXPECT_EQ(db.schema_version_found(), 8);
  EXPECT_EQ(db.connection().pragma_int("user_version"), kSchemaVersion);
  EXPECT_EQ(db.session(1).status, SessionStatus::kClosed);
  EXPECT_EQ(db.session(1).site, "");
  // Version 10 after it: the loop's rate and the participant model, not known.
  EXPECT_FALSE(db.session(1).rate_Hz.has_value());
  EXPECT_EQ(db.session(1).participant_model, "");
  const std::vector<std::string> cols = columns(db.connection(), "session");
  ASSERT_GE(cols.size(), 3u);
  EXPECT_EQ(std::vector<std::string>(cols.end() - 3, cols.end()),
            (std::vector<std::string>{"site TEXT", "rate_Hz REAL", "participant_model TEXT"}));
  db.connection().exec("UPDATE session SET site = 'Basel'");
  EXPECT_EQ(db.session(1).site, "Basel");
}

TEST(Schema, FailedMigrationLeavesTheFileAsItWas) {
  testing::TempDir dir;
  const auto path = dir.file("broken_v1.db");
  {
    Database db(path);
    // A version 1 file whose trial table lost its drop column: step 2 fails.
    db.exec("CREATE TABLE trial (id INTEGER PRIMARY KEY, status TEXT); PRAGMA user_version = 1; "
            "PRAGMA application_id = 1212956994;");
  }
  try {
    StudyDb db(path);
    FAIL() << "migrated a damaged version 1 file";
  } catch (const DbError& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr(path.string()), HasSubstr("migration to schema version 2"),
                                HasSubstr("left at version 1")));
  }
  Database raw(path);
  EXPECT_EQ(raw.pragma_int("user_version"), 1);
  EXPECT_EQ(tables(raw), std::vector<std::string>{"trial"});
}

}  // namespace
}  // namespace hapticlab::db
