#pragma once
// CrashNote: when this process dies of a crash signal (SIGSEGV, SIGBUS,
// SIGFPE, SIGILL, SIGABRT) while a trial runs, say why before it dies.
//
// An in-process device plugin shares the session's process, so its crash
// takes the session down with the trial left 'running'; the next session
// of that participant recovers the trial as aborted, and without this note
// could only say "crashed or killed". The handler appends one line,
//   abort_reason=device_crashed: SIGSEGV in read
// to the participant's lock file (db/session_lock.h), which that recovery
// records as the trial's reason. "in read" / "in write" when the crash
// happened on the haptic loop's thread inside that device call; otherwise
// "crashed: SIGSEGV in the session process (not in a device call)".
//
// Then, best effort, it halts the device (Device::halt(): zero force) under
// a 1 s alarm, since a plugin that just crashed may hang in its own halt,
// and dies of the signal as it would have (its default action: the exit
// status and any core dump are unchanged; also when the alarm cuts the
// halt short, or a second crash signal comes from inside it).
//
// The handler only loads atomics, copies bytes into a static buffer and
// calls pwrite(2), alarm(2) and raise(3): async-signal-safe, apart from the
// device's own halt(). One CrashNote is armed at a time per process (a
// second one throws std::logic_error); the destructor restores the handlers
// that were there before.

#include <atomic>

#include "core/device/device.h"
#include "core/loop/haptic_loop.h"
#include "db/session_lock.h"

namespace hapticlab::sessions {

class CrashNote {
 public:
  // `target`: the lock file's end (StudySession::crash_note_target()); an
  // fd of -1 arms nothing. `loop` and `device` must outlive the note.
  CrashNote(db::SessionLock::CrashNoteTarget target, const HapticLoop& loop, Device& device);
  ~CrashNote();
  CrashNote(const CrashNote&) = delete;
  CrashNote& operator=(const CrashNote&) = delete;

 private:
  bool armed_ = false;
};

}  // namespace hapticlab::sessions
