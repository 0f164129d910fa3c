#include "db/session_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <sstream>
#include <thread>
#include <utility>

#include "db/study_db.h"

namespace hapticlab::db {
namespace {

std::string errno_text(int err) { return std::strerror(err); }

std::string read_all(int fd) {
  std::string text;
  char buffer[512];
  off_t offset = 0;
  for (;;) {
    const ssize_t n = ::pread(fd, buffer, sizeof buffer, offset);
    if (n <= 0) break;
    text.append(buffer, static_cast<std::size_t>(n));
    offset += n;
    if (text.size() > 4096) break;  // ours are ~100 bytes; never read a stranger's file whole
  }
  return text;
}

std::optional<SessionOwner> parse_owner(const std::string& text) {
  if (text.empty()) return std::nullopt;
  SessionOwner owner;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const auto eq = line.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = line.substr(0, eq), value = line.substr(eq + 1);
    if (key == "pid") owner.pid = std::strtol(value.c_str(), nullptr, 10);
    else if (key == "host") owner.host = value;
    else if (key == "started_utc") owner.started_utc = value;
    else if (key == "what") owner.what = value;
    else if (key == "abort_reason") owner.abort_reason = value;
  }
  return owner;
}

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "unknown";
  return name;
}

// Locked `fd` is ours: say who we are, for a refused second session.
void write_owner(int fd, const char* what, const std::string& abort_reason = {}) {
  std::ostringstream out;
  out << "pid=" << ::getpid() << "\nhost=" << host_name() << "\nstarted_utc=" << iso8601_utc_now()
      << "\nwhat=" << what << "\n";
  if (!abort_reason.empty()) {
    std::string line = abort_reason.substr(0, 1000);
    for (char& c : line)
      if (c == '\n' || c == '\r') c = ' ';
    out << "abort_reason=" << line << "\n";
  }
  const std::string text = out.str();
  // Best effort: the lock itself is what excludes; the text only explains.
  if (::ftruncate(fd, 0) == 0) {
    [[maybe_unused]] const ssize_t n = ::pwrite(fd, text.data(), text.size(), 0);
  }
}

enum class Attempt { kLocked, kBusy, kReplaced };

// One try: the lock on the file now at `path`, held through `fd`.
Attempt try_lock(int fd, const std::filesystem::path& path) {
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) return Attempt::kBusy;
  // The holder we waited for may have unlinked the file after we opened
  // it; then we hold a lock on a file nobody else will ever look at.
  struct stat ours{}, named{};
  if (::fstat(fd, &ours) != 0 || ::stat(path.c_str(), &named) != 0 || ours.st_ino != named.st_ino ||
      ours.st_dev != named.st_dev)
    return Attempt::kReplaced;
  return Attempt::kLocked;
}

}  // namespace

std::string SessionOwner::describe() const {
  std::string s = "pid " + (pid > 0 ? std::to_string(pid) : std::string("unknown"));
  if (!host.empty()) s += " on host " + host;
  if (!started_utc.empty()) s += ", since " + started_utc;
  return s;
}

std::filesystem::path SessionLock::lock_path(const std::filesystem::path& db_path, std::int64_t participant_id) {
  // Any spelling of the same file (relative, through a symlinked folder)
  // must give the same lock.
  std::error_code ec;
  std::filesystem::path canonical = std::filesystem::weakly_canonical(db_path, ec);
  if (ec) canonical = std::filesystem::absolute(db_path);
  return canonical.string() + "-session-" + std::to_string(participant_id) + ".lock";
}

SessionLock SessionLock::acquire(const std::filesystem::path& db_path, std::int64_t participant_id,
                                 const std::string& code, std::chrono::milliseconds wait) {
  const std::filesystem::path path = lock_path(db_path, participant_id);
  const auto deadline = std::chrono::steady_clock::now() + wait;
  for (;;) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
      throw std::runtime_error(path.string() + ": cannot create the session lock file: " + errno_text(errno) +
                               " (the folder of the study database must be writable to run a session)");
    const Attempt a = try_lock(fd, path);
    if (a == Attempt::kLocked) {
      SessionLock lock(fd, path);
      lock.stale_owner_ = parse_owner(read_all(fd));
      write_owner(fd, "session");
      return lock;
    }
    if (a == Attempt::kBusy) {
      const std::optional<SessionOwner> owner = parse_owner(read_all(fd));
      const bool brief = owner && owner->what == "recovery";
      if (std::chrono::steady_clock::now() >= deadline || (owner && !brief)) {
        ::close(fd);
        throw SessionBusyError("participant " + code + " has a session running" +
                               (owner ? " (" + owner->describe() + ")" : std::string()) +
                               "; a second session for the same participant is refused. Wait for it to end, "
                               "or stop it (Ctrl-C in its terminal)");
      }
    }
    ::close(fd);
    if (a == Attempt::kBusy) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

std::optional<SessionLock> SessionLock::try_acquire(const std::filesystem::path& db_path,
                                                    std::int64_t participant_id, const char* what) {
  const std::filesystem::path path = lock_path(db_path, participant_id);
  for (;;) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) return std::nullopt;
    const Attempt a = try_lock(fd, path);
    if (a == Attempt::kLocked) {
      SessionLock lock(fd, path);
      lock.stale_owner_ = parse_owner(read_all(fd));
      write_owner(fd, what);
      return lock;
    }
    ::close(fd);
    if (a == Attempt::kBusy) return std::nullopt;
  }
}

SessionLock::SessionLock(SessionLock&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      path_(std::move(other.path_)),
      stale_owner_(std::move(other.stale_owner_)),
      keep_file_(other.keep_file_) {}

void SessionLock::record_abort_reason(const std::string& reason) noexcept {
  if (fd_ < 0) return;
  try {
    write_owner(fd_, "session", reason);
    keep_file_ = true;
  } catch (...) {
    // Out of memory for a string: the trial is then recovered as interrupted.
  }
}

void SessionLock::clear_abort_reason() noexcept {
  if (fd_ < 0) return;
  try {
    write_owner(fd_, "session");
    keep_file_ = false;
  } catch (...) {
    // Kept: the reason is then the one recorded, which is still true.
  }
}

SessionLock::CrashNoteTarget SessionLock::crash_note_target() const noexcept {
  struct stat st {};
  if (fd_ < 0 || ::fstat(fd_, &st) != 0) return {};
  return {fd_, static_cast<long>(st.st_size)};
}

SessionLock::~SessionLock() {
  if (fd_ < 0) return;
  // Unlink first, while still holding the lock (see the header).
  if (!keep_file_) ::unlink(path_.c_str());
  ::close(fd_);
}

}  // namespace hapticlab::db
