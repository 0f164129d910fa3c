#include "planning/plan_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "core/common/utc_time.h"

namespace hapticlab::planning {
namespace {

std::string plan_lock_holder(int fd) {
  char text[512] = {};
  const ssize_t n = ::pread(fd, text, sizeof text - 1, 0);
  std::string s(text, n > 0 ? static_cast<std::size_t>(n) : 0);
  for (char& c : s)
    if (c == '\n') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::string plan_lock_host() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "unknown";
  return name;
}

}  // namespace

std::filesystem::path PlanLock::lock_path(const std::filesystem::path& out_dir) {
  return out_dir / "plan_power.db.lock";
}

PlanLock PlanLock::acquire(const std::filesystem::path& out_dir) {
  const std::filesystem::path path = lock_path(out_dir);
  for (;;) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
      throw std::runtime_error(path.string() + ": cannot create the plan's lock file: " + std::strerror(errno) +
                               " (--out must be a folder this user can write)");
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const std::string holder = plan_lock_holder(fd);
      ::close(fd);
      throw PlanBusyError(out_dir.string() + " is in use by another plan power run (" +
                          (holder.empty() ? std::string("its pid is not written yet") : holder) +
                          "); two runs on one folder would simulate the same studies. Wait for it to end, stop "
                          "it (Ctrl-C in its terminal), or give this run another --out");
    }
    // A holder that let go meanwhile unlinked the file we opened: then
    // this lock is on a file nobody else will look at; take the new one.
    struct stat ours {}, named {};
    if (::fstat(fd, &ours) != 0 || ::stat(path.c_str(), &named) != 0 || ours.st_ino != named.st_ino ||
        ours.st_dev != named.st_dev) {
      ::close(fd);
      continue;
    }
    const std::string me = "pid " + std::to_string(::getpid()) + " on host " + plan_lock_host() + ", since " +
                           utc_now_iso8601() + "\n";
    // Best effort: the lock excludes; the text only explains.
    if (::ftruncate(fd, 0) == 0) {
      [[maybe_unused]] const ssize_t n = ::pwrite(fd, me.data(), me.size(), 0);
    }
    return PlanLock(fd, path);
  }
}

PlanLock::PlanLock(PlanLock&& other) noexcept : fd_(std::exchange(other.fd_, -1)), path_(std::move(other.path_)) {}

PlanLock::~PlanLock() {
  if (fd_ < 0) return;
  ::unlink(path_.c_str());
  ::close(fd_);
}

}  // namespace hapticlab::planning
