#pragma once
// At most one `plan power` run per output folder. Two runs on one folder
// would both simulate the studies missing from plan_power.db and the
// second to finish one would fail on its row ("UNIQUE constraint
// failed"), after a long wait, with a message about free space. As
// sessions do (db/session_lock.h), the run holds an flock(2) lock on a file
// beside the database, "plan_power.db.lock", which the kernel releases
// however the holder dies; the holder writes its pid, host and start time
// into it, so a second run is refused naming who holds the folder.
#include <filesystem>
#include <stdexcept>
#include <string>

namespace hapticlab::planning {

// Thrown when another live run holds the folder; what() says who.
class PlanBusyError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class PlanLock {
 public:
  // Takes the lock of `out_dir` (which must exist) at once, or throws
  // PlanBusyError naming the holder; std::runtime_error when the lock file
  // cannot be made (naming it and the cause).
  static PlanLock acquire(const std::filesystem::path& out_dir);

  PlanLock(PlanLock&& other) noexcept;
  PlanLock& operator=(PlanLock&&) = delete;
  PlanLock(const PlanLock&) = delete;
  PlanLock& operator=(const PlanLock&) = delete;
  // Unlinks the file (while still holding the lock) and releases it. Never throws.
  ~PlanLock();

  static std::filesystem::path lock_path(const std::filesystem::path& out_dir);

 private:
  PlanLock(int fd, std::filesystem::path path) : fd_(fd), path_(std::move(path)) {}
  int fd_ = -1;
  std::filesystem::path path_;
};

}  // namespace hapticlab::planning
