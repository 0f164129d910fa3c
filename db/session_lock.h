#pragma once
// SessionLock: at most one live session per participant and study file,
// across processes, and a way to tell a live session from a dead one.
//
// Why a lock file beside the database and not a row in it: a row cannot
// say whether the process that wrote it is still alive, and a process
// killed with SIGKILL cannot clear it. An flock(2) lock is released by the
// kernel when its holder dies, however it dies, so "the lock is free" means
// exactly "no session for this participant is running". The lock is on a
// separate file, "<db>-session-<participant id>.lock", never on the
// database itself: closing a descriptor of the database file would drop
// SQLite's own POSIX locks (see StudyDb).
//
// The holder writes its pid, host and start time into the file, so a second
// session is refused with who holds it. On release the holder unlinks the
// file while still holding the lock; an acquirer that locked a file which
// was unlinked meanwhile (its inode no longer matches the path) retries, so
// two processes never both believe they hold it.
//
// A file left by a killed holder stays on disk, unlocked: the next acquirer
// takes it over, and reports that it did (stale_owner()).

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>

namespace hapticlab::db {

// Thrown when another live process holds the lock; what() says who.
class SessionBusyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// What a lock file says about its holder.
struct SessionOwner {
  long pid = 0;
  std::string host;
  std::string started_utc;  // ISO 8601
  std::string what;         // "session" or "recovery"
  // Why the holder's running trial ended, when it could not store that in
  // the database itself (the disk was full): recovery records this instead
  // of kInterruptedReason.
  std::string abort_reason;
  // "pid 1234 on host lab-pc, since 2026-11-23T19:30:00.000Z"
  std::string describe() const;
};

class SessionLock {
 public:
  // The lock file of participant `participant_id` in the study file `db_path`.
  static std::filesystem::path lock_path(const std::filesystem::path& db_path, std::int64_t participant_id);

  // Takes the lock for a session, waiting up to `wait` for a short-lived
  // holder (another process's recovery) to let go. Throws SessionBusyError
  // naming the participant `code` and the holder when a session holds it,
  // std::runtime_error when the lock file cannot be made (naming the path
  // and the cause).
  static SessionLock acquire(const std::filesystem::path& db_path, std::int64_t participant_id,
                             const std::string& code,
                             std::chrono::milliseconds wait = std::chrono::milliseconds(2000));

  // Takes the lock only if it is free right now (no session is running);
  // nullopt otherwise, or when the lock file cannot be made (a read-only
  // folder: then nobody can be recovered from here either).
  static std::optional<SessionLock> try_acquire(const std::filesystem::path& db_path, std::int64_t participant_id,
                                                const char* what);

  SessionLock(SessionLock&& other) noexcept;
  SessionLock& operator=(SessionLock&&) = delete;
  SessionLock(const SessionLock&) = delete;
  SessionLock& operator=(const SessionLock&) = delete;
  // Unlinks the file and releases the lock. Never throws.
  ~SessionLock();

  // The holder whose file this lock took over (it had died without
  // releasing, or left a reason behind), if any.
  const std::optional<SessionOwner>& stale_owner() const noexcept { return stale_owner_; }

  // For a running trial that ended in a way the database could not be told
  // (it is full): writes `reason` into the lock file and keeps the file on
  // release, so whoever recovers the trial next records the real reason.
  // Rewrites the file in place (a few hundred bytes, within the block it
  // already has), which works on a full disk. Never throws.
  void record_abort_reason(const std::string& reason) noexcept;
  // Takes back what record_abort_reason wrote: the trial ended after all
  // and its own reason is in the database. Never throws.
  void clear_abort_reason() noexcept;

  // Where a crash handler may append one more "abort_reason=..." line (the
  // last one counts) without allocating: the lock file's descriptor and
  // its end. Valid while the lock is held and nothing else writes it.
  struct CrashNoteTarget {
    int fd = -1;
    long offset = 0;
  };
  CrashNoteTarget crash_note_target() const noexcept;

 private:
  SessionLock(int fd, std::filesystem::path path) : fd_(fd), path_(std::move(path)) {}

  int fd_ = -1;
  std::filesystem::path path_;
  std::optional<SessionOwner> stale_owner_;
  bool keep_file_ = false;
};

}  // namespace hapticlab::db
