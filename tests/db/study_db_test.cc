#include "db/study_db.h"

#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/settings/settings_json.h"
#include "core/common/sha256.h"
#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

TEST(StudyDb, StoresStudyWithProtocolHashSeedAndTime) {
  StudyDb db(":memory:");
  const std::string protocol = R"({"study": "Fidelity", "seed": 7})";
  const std::int64_t id = db.add_study({"Fidelity", protocol, 18'000'000'000'000'000'000ull, "0.1.0"});
  const StudyRow r = db.study(id);
  EXPECT_EQ(r.name, "Fidelity");
  EXPECT_EQ(r.protocol_json, protocol);
  EXPECT_EQ(r.protocol_sha256, sha256_hex(protocol));
  EXPECT_EQ(r.seed, 18'000'000'000'000'000'000ull);  // above INT64_MAX: kept exactly
  EXPECT_EQ(r.software_version, "0.1.0");
  EXPECT_THAT(r.created_utc, ::testing::MatchesRegex(R"(20[0-9][0-9]-[0-9][0-9]-[0-9][0-9]T[0-9:.]+Z)"));
  EXPECT_THROW(db.study(id + 1), DbError);
}

TEST(StudyDb, SettingsAreStoredInFullAndReadBack) {
  StudyDb db(":memory:");
  const std::int64_t study = db.add_study({"s", "{}", 1, "v"});
  const NamedSettings friction =
      load_settings_file(std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples/settings/friction.json");
  const std::int64_t id = db.add_setting(study, friction);
  EXPECT_EQ(nlohmann::json::parse(db.setting_json(id)), settings_to_json(friction));
  EXPECT_EQ(settings_to_json(db.setting(id)), settings_to_json(friction));
  EXPECT_THROW(db.add_setting(study, friction), DbError) << "setting names are unique within a study";
}

TEST(StudyDb, TrialLifecycleAndSchedule) {
  StudyDb db(":memory:");
  const std::int64_t study = db.add_study({"s", "{}", 1, "v"});
  const std::int64_t p = db.add_participant(study, "P07");
  EXPECT_EQ(db.find_participant(study, "P07"), p);
  EXPECT_FALSE(db.find_participant(study, "P08").has_value());
  const std::int64_t hf = db.add_setting_json(study, "High Fidelity", "{}");
  const std::int64_t t2 = db.add_trial({p, "clip", hf, 1, 1, 2});
  const std::int64_t t1 = db.add_trial({p, "dissection", hf, 1, 1, 1});
  EXPECT_THROW(db.add_trial({p, "clip", hf, 2, 2, 2}), DbError) << "position is unique per participant";
  EXPECT_EQ(db.next_planned_trial(p), t1);

  const std::int64_t session = db.begin_session(p, "sim", "wall", 1000.0);
  EXPECT_THROW(db.end_trial(t1, TrialStatus::kComplete), DbError) << "a planned trial cannot end";
  db.start_trial(t1, session);
  EXPECT_THROW(db.start_trial(t1, session), DbError) << "a running trial cannot start again";
  EXPECT_EQ(db.trial(t1).status, TrialStatus::kRunning);
  EXPECT_EQ(db.next_planned_trial(p), t2);
  db.end_trial(t1, TrialStatus::kComplete);
  db.start_trial(t2, session);
  EXPECT_THROW(db.end_trial(t2, TrialStatus::kPlanned), DbError);
  db.end_trial(t2, TrialStatus::kAborted, "operator: participant asked to stop");
  db.end_session(session);

  const std::vector<TrialRow> trials = db.trials(study);
  ASSERT_EQ(trials.size(), 2u);
  EXPECT_EQ(trials[0].id, t1);  // by position
  EXPECT_EQ(trials[0].status, TrialStatus::kComplete);
  EXPECT_TRUE(trials[0].started_unix_s && trials[0].ended_unix_s);
  EXPECT_LE(*trials[0].started_unix_s, *trials[0].ended_unix_s);
  EXPECT_EQ(trials[1].status, TrialStatus::kAborted);
  EXPECT_EQ(trials[1].abort_reason, "operator: participant asked to stop");
  EXPECT_EQ(trials[1].session_id, session);
  EXPECT_EQ(trials[1].task, "clip");
  EXPECT_EQ(db.session(session).status, SessionStatus::kClosed);
  EXPECT_FALSE(db.next_planned_trial(p).has_value());
}

TEST(StudyDb, AbortedTrialIsRequeuedInPlaceAndRunsBeforeLaterPositions) {
  StudyDb db(":memory:");
  const std::int64_t study = db.add_study({"s", "{}", 1, "v"});
  const std::int64_t p = db.add_participant(study, "P01");
  const std::int64_t hf = db.add_setting_json(study, "High Fidelity", "{}");
  const std::int64_t t1 = db.add_trial({p, "clip", hf, 1, 1, 1});
  const std::int64_t t2 = db.add_trial({p, "clip", hf, 2, 1, 2});
  const std::int64_t session = db.begin_session(p, "sim", "wall", 1000.0);
  EXPECT_THROW(db.requeue_trial(t1), DbError) << "a planned trial is already queued";

  db.start_trial(t1, session);
  db.end_trial(t1, TrialStatus::kAborted, "operator abort");
  const std::int64_t copy = db.requeue_trial(t1);
  EXPECT_GT(copy, t2);
  // The copy has the larger id but the earlier position: it runs first.
  EXPECT_EQ(db.next_planned_trial(p), copy);
  const TrialRow c = db.trial(copy);
  EXPECT_EQ(c.status, TrialStatus::kPlanned);
  EXPECT_EQ(c.position, 1);
  EXPECT_EQ(c.repetition, 1);
  EXPECT_EQ(c.task, "clip");
  EXPECT_EQ(c.setting_id, hf);
  EXPECT_FALSE(c.session_id.has_value());
  EXPECT_EQ(db.trial(t1).status, TrialStatus::kAborted) << "the aborted original is kept as it was";
  try {
    db.requeue_trial(t1);
    FAIL() << "re-queued the same trial twice";
  } catch (const DbError& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr("position 1"), HasSubstr("trial " + std::to_string(copy))));
  }

  // Aborted again: the copy of the copy still comes before position 2, and
  // the schedule lists the slot's attempts in the order they were made.
  db.start_trial(copy, session);
  db.end_trial(copy, TrialStatus::kAborted, "device fault");
  const std::int64_t copy2 = db.requeue_trial(copy);
  EXPECT_EQ(db.next_planned_trial(p), copy2);
  std::vector<std::int64_t> order;
  for (const TrialRow& t : db.trials(study)) order.push_back(t.id);
  EXPECT_EQ(order, (std::vector<std::int64_t>{t1, copy, copy2, t2}));
  // Two live trials at one position are refused by the schema itself.
  EXPECT_THROW(db.add_trial({p, "clip", hf, 1, 1, 1}), DbError);
}

TEST(StudyDb, DeviceCountersReplaceAndReadBackInNameOrder) {
  StudyDb db(":memory:");
  const std::int64_t trial = testing::make_trial(db);
  EXPECT_TRUE(db.device_counters(trial).empty());
  db.set_device_counters(trial, {{"timeouts", 1}, {"packets_sent", 5'000'000'000}});
  db.set_device_counters(trial, {{"timeouts", 2}, {"stale", 7}});  // replaces, never adds up
  const std::vector<std::pair<std::string, std::uint64_t>> expected = {{"stale", 7}, {"timeouts", 2}};
  EXPECT_EQ(db.device_counters(trial), expected);
}

TEST(StudyDb, LoopTimingAndEvents) {
  StudyDb db(":memory:");
  const std::int64_t trial = testing::make_trial(db);
  LoopTimingSummary t;
  t.count = 120'000;
  t.mean_period_s = 1.0001e-3;
  t.p50_period_s = 1.0005e-3;
  t.p99_period_s = 1.0405e-3;
  t.max_period_s = 2.5e-3;
  t.overruns = 4;
  t.rejected = 1;
  db.set_loop_timing(trial, t, 12, 3);
  const std::optional<LoopTimingRow> r = db.loop_timing(trial);
  ASSERT_TRUE(r && r->timing);
  EXPECT_EQ(r->timing->count, 120'000u);
  EXPECT_EQ(r->timing->p99_period_s, 1.0405e-3);
  EXPECT_EQ(r->timing->max_period_s, 2.5e-3);
  EXPECT_EQ(r->timing->overruns, 4u);
  EXPECT_EQ(r->dropped_samples, 12u);
  EXPECT_EQ(r->dropped_events, 3u);

  db.add_event({trial, 2.0, "operator_note", -1, 0, "participant sneezed, 2 s pause"});
  db.add_event({trial, 1.0, "clip_applied", 1, 2, ""});
  const std::vector<EventRow> events = db.events(trial);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].type, "clip_applied");  // by time
  EXPECT_EQ(events[0].instrument, 1);
  EXPECT_EQ(events[0].item_index, 2);
  EXPECT_EQ(events[1].detail, "participant sneezed, 2 s pause");
}

TEST(StudyDb, OpeningMarksRunningTrialsAbortedAndKeepsTheirSamples) {
  testing::TempDir dir;
  const auto path = dir.file("crashed.db");
  std::int64_t trial = 0, session = 0;
  {
    StudyDb db(path);
    trial = testing::make_trial(db);
    session = *db.trial(trial).session_id;
    std::vector<StoredSample> samples;
    for (std::uint64_t k = 0; k < 10; ++k) {
      const LoopSample s = testing::make_sample(k);
      samples.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[0]});
    }
    db.insert_chunk(trial, 0, samples);
    // ... and the runner dies here: the trial is still 'running'.
  }
  StudyDb reader(path, {OpenOptions::Integrity::kFull, /*recover=*/false});
  EXPECT_EQ(reader.trial(trial).status, TrialStatus::kRunning) << "a reader must not recover";

  StudyDb db(path);
  EXPECT_EQ(db.recovery().trials_aborted, 1);
  EXPECT_EQ(db.recovery().sessions_interrupted, 1);
  const TrialRow t = db.trial(trial);
  EXPECT_EQ(t.status, TrialStatus::kAborted);
  EXPECT_EQ(t.abort_reason, "interrupted (runner crashed or was killed)");
  EXPECT_EQ(db.samples(trial, 0).size(), 10u);
  EXPECT_EQ(db.session(session).status, SessionStatus::kInterrupted);

  StudyDb again(path);
  EXPECT_EQ(again.recovery().trials_aborted, 0);
}

TEST(StudyDb, DamagedFileIsRefusedByTheIntegrityCheck) {
  testing::TempDir dir;
  const auto path = dir.file("damaged.db");
  {
    StudyDb db(path);
    const std::int64_t trial = testing::make_trial(db);
    for (int k = 0; k < 200; ++k) db.add_event({trial, k * 0.01, "contact_start", 0, k, std::string(300, 'x')});
    db.connection().exec("PRAGMA wal_checkpoint(TRUNCATE)");
  }
  // Scribble over the middle of the file (table and index pages).
  const auto size = std::filesystem::file_size(path);
  ASSERT_GT(size, 40'000u);
  {
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(size / 2));
    const std::string junk(8192, '\x5a');
    f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
  }
  try {
    StudyDb db(path);
    FAIL() << "opened a damaged file";
  } catch (const DbError& e) {
    EXPECT_THAT(e.what(), AllOf(HasSubstr(path.string()), HasSubstr("integrity_check"), HasSubstr("damaged")));
  }
}

TEST(StudyDb, ReadOnlyOpenNeedsACurrentFile) {
  testing::TempDir dir;
  const auto path = dir.file("ro.db");
  { StudyDb db(path); testing::make_trial(db); }
  OpenOptions ro;
  ro.read_only = true;
  StudyDb db(path, ro);
  EXPECT_EQ(db.trials().size(), 1u);
  EXPECT_THROW(db.add_participant(1, "P99"), DbError);
}

}  // namespace
}  // namespace hapticlab::db
