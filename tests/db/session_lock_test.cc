#include "db/session_lock.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db_test_util.h"

namespace hapticlab::db {
namespace {

using ::testing::HasSubstr;

// A study file with one trial running; its id and its participant's.
std::pair<std::int64_t, std::int64_t> running_trial(const std::filesystem::path& path) {
  StudyDb db(path);
  const std::int64_t trial = testing::make_trial(db);
  return {trial, db.trial(trial).participant_id};
}

TEST(SessionLock, ASecondHolderIsRefusedNamingTheFirst) {
  testing::TempDir dir;
  const auto db = dir.file("study.db");
  const SessionLock first = SessionLock::acquire(db, 3, "P03");
  EXPECT_FALSE(first.stale_owner().has_value());
  EXPECT_TRUE(std::filesystem::exists(SessionLock::lock_path(db, 3)));
  try {
    // flock locks belong to the open file, so a second open in the same
    // process conflicts exactly as another process's would.
    SessionLock::acquire(db, 3, "P03", std::chrono::milliseconds(50));
    FAIL() << "a second session for P03 was allowed";
  } catch (const SessionBusyError& e) {
    EXPECT_THAT(e.what(), HasSubstr("participant P03 has a session running"));
    EXPECT_THAT(e.what(), HasSubstr("pid " + std::to_string(::getpid())));
  }
  EXPECT_FALSE(SessionLock::try_acquire(db, 3, "recovery").has_value());
  // Another participant is independent.
  EXPECT_TRUE(SessionLock::try_acquire(db, 4, "recovery").has_value());
}

TEST(SessionLock, ReleaseRemovesTheFileAndFreesTheLock) {
  testing::TempDir dir;
  const auto db = dir.file("study.db");
  { const SessionLock lock = SessionLock::acquire(db, 1, "P01"); }
  EXPECT_FALSE(std::filesystem::exists(SessionLock::lock_path(db, 1)));
  const SessionLock again = SessionLock::acquire(db, 1, "P01");
  EXPECT_FALSE(again.stale_owner().has_value()) << "a released lock is not stale";
}

// What a holder killed with SIGKILL leaves: its file, with its pid, and no
// lock (the kernel dropped it). The next holder takes it and says whose.
TEST(SessionLock, AnUnlockedFileLeftBehindIsTakenOverAsStale) {
  testing::TempDir dir;
  const auto db = dir.file("study.db");
  std::ofstream(SessionLock::lock_path(db, 2)) << "pid=424242\nhost=lab-pc\nstarted_utc=2026-01-01T00:00:00.000Z\n"
                                                  "what=session\n";
  const SessionLock lock = SessionLock::acquire(db, 2, "P02");
  ASSERT_TRUE(lock.stale_owner().has_value());
  EXPECT_EQ(lock.stale_owner()->pid, 424242);
  EXPECT_EQ(lock.stale_owner()->describe(), "pid 424242 on host lab-pc, since 2026-01-01T00:00:00.000Z");
}

TEST(SessionLock, ALockFileThatCannotBeMadeIsNamedWithItsCause) {
  // A folder that does not exist fails for root too (a read-only folder
  // would not: root writes anywhere).
  testing::TempDir dir;
  const auto db = dir.file("missing") / "study.db";
  try {
    SessionLock::acquire(db, 1, "P01");
    FAIL() << "a lock file was made in a folder that does not exist";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr(SessionLock::lock_path(db, 1).string()));
    EXPECT_THAT(e.what(), HasSubstr("cannot create the session lock file: No such file or directory"));
  }
  EXPECT_FALSE(SessionLock::try_acquire(db, 1, "recovery").has_value()) << "nobody to recover from here";
}

// Opening the file recovers only sessions that are gone: a trial whose
// participant's lock is held (a live session, another station) is left
// running; once the lock is free, the next open recovers it.
TEST(SessionLock, OpeningRecoversOnlyDeadSessions) {
  testing::TempDir dir;
  const auto path = dir.file("study.db");
  const auto [trial, participant] = running_trial(path);
  {
    const SessionLock live = SessionLock::acquire(path, participant, "P01");
    StudyDb db(path);  // recover = true
    EXPECT_EQ(db.recovery().trials_aborted, 0);
    EXPECT_EQ(db.trial(trial).status, TrialStatus::kRunning);
  }
  StudyDb db(path);
  EXPECT_EQ(db.recovery().trials_aborted, 1);
  EXPECT_EQ(db.recovery().sessions_interrupted, 1);
  EXPECT_EQ(db.trial(trial).status, TrialStatus::kAborted);
  EXPECT_FALSE(std::filesystem::exists(SessionLock::lock_path(path, participant)))
      << "recovery releases the lock it took";
}

// A session whose database is full cannot store why its trial ended; it
// leaves the reason in its lock file, and whoever recovers the trial next
// records that instead of "crashed or killed".
TEST(SessionLock, AReasonLeftInTheLockFileIsWhatRecoveryRecords) {
  testing::TempDir dir;
  const auto path = dir.file("study.db");
  const auto [trial, participant] = running_trial(path);
  {
    SessionLock lock = SessionLock::acquire(path, participant, "P01");
    lock.record_abort_reason("storage failure: database or disk is full\nsecond line");
  }
  EXPECT_TRUE(std::filesystem::exists(SessionLock::lock_path(path, participant)));
  StudyDb db(path);
  EXPECT_EQ(db.recovery().trials_aborted, 1);
  EXPECT_EQ(db.trial(trial).abort_reason, "storage failure: database or disk is full second line");
}

}  // namespace
}  // namespace hapticlab::db
