#pragma once
// Real-time scheduling for the haptic loop thread (`--realtime`): SCHED_FIFO
// at a chosen priority, pinned to one CPU, with the process's memory locked
// so a page fault never stalls an update.
//
// Linux grants SCHED_FIFO to root, to a process with CAP_SYS_NICE, or up to
// the RLIMIT_RTPRIO a user is given (/etc/security/limits.conf, "@realtime
// - rtprio 95"). When it is refused the loop runs on the normal scheduler:
// the operator is told, and a study on a quiet machine still works, with
// more jitter. docs/devices.md has the PREEMPT_RT guidance.

#include <string>

namespace hapticlab {

struct RealtimeOptions {
  bool enabled = false;
  // SCHED_FIFO priority, 1..99. 80 stays above the kernel's threaded IRQ
  // handlers (50 on PREEMPT_RT) so the loop is not preempted by them, and
  // below the kernel's own watchdogs (99).
  int priority = 80;
  // CPU the loop is pinned to, or -1 for the last one (CPU 0 takes most
  // interrupts and housekeeping by default).
  int cpu = -1;
};

struct RealtimeResult {
  bool scheduled = false;  // SCHED_FIFO at the priority
  bool pinned = false;     // affinity set
  int cpu = -1;            // the CPU it was pinned to
  int sched_errno = 0;     // why not, when not
  int affinity_errno = 0;
};

// Applies the options to the calling thread. Real-time safe enough for the
// loop thread's start: two system calls, no allocation. Does nothing (and
// returns all false) when !options.enabled.
RealtimeResult apply_realtime_to_this_thread(const RealtimeOptions& options) noexcept;

// Locks the process's current and future memory (mlockall). Returns an
// empty string, or why it failed.
std::string lock_process_memory();

// For the operator, before a session: locks memory and tries the options on
// a short-lived thread, and says in one line what the loop will get
// ("real-time: SCHED_FIFO priority 80 on CPU 1, memory locked", or what was
// refused and how to allow it). Throws std::invalid_argument for a priority
// outside 1..99 or a CPU the machine does not have. `granted`, if given,
// gets what the trial thread got.
std::string prepare_realtime(const RealtimeOptions& options, RealtimeResult* granted = nullptr);

}  // namespace hapticlab
