#include "sessions/crash_note.h"

#include <signal.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cstring>
#include <stdexcept>

namespace hapticlab::sessions {
namespace {

constexpr int kSignals[] = {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT};
constexpr int kNumSignals = sizeof kSignals / sizeof kSignals[0];

// What the handler reads. Written before the handlers are installed and
// cleared after they are removed, so a handler never sees them half set.
std::atomic<bool> g_armed{false};
// The crash signal being handled, for the alarm that cuts a hung halt()
// short: the process still dies of the crash, not of SIGALRM.
std::atomic<int> g_crash_signal{0};
int g_fd = -1;
long g_offset = 0;
const HapticLoop* g_loop = nullptr;
Device* g_device = nullptr;
struct sigaction g_previous[kNumSignals];

const char* signal_name(int sig) noexcept {
  switch (sig) {
    case SIGSEGV: return "SIGSEGV";
    case SIGBUS: return "SIGBUS";
    case SIGFPE: return "SIGFPE";
    case SIGILL: return "SIGILL";
    case SIGABRT: return "SIGABRT";
  }
  return "a crash signal";
}

// strcat into a fixed buffer, bounded; async-signal-safe.
struct Line {
  char text[256];
  std::size_t size = 0;
  void add(const char* s) noexcept {
    while (*s != '\0' && size + 1 < sizeof text) text[size++] = *s++;
  }
};

// Every crash signal back to its default action, first thing: a second
// crash inside the device's halt() then ends the process instead of
// entering this handler again (SA_RESETHAND resets only the delivered one).
void reset_crash_signals() noexcept {
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  for (int s : kSignals) ::sigaction(s, &dfl, nullptr);
}

void on_alarm(int) {
  // halt() did not return within its second: die of the crash signal.
  const int sig = g_crash_signal.load();
  ::raise(sig != 0 ? sig : SIGABRT);
}

void on_crash(int sig) {
  reset_crash_signals();
  if (g_armed.exchange(false)) {
    g_crash_signal.store(sig);
    Line line;
    line.add("abort_reason=");
    const bool loop_thread = g_loop->loop_thread_id() == static_cast<int>(::syscall(SYS_gettid));
    const DeviceCall call = g_loop->device_call().load(std::memory_order_acquire);
    if (loop_thread && call != DeviceCall::kNone) {
      line.add("device_crashed: ");
      line.add(signal_name(sig));
      line.add(" in ");
      line.add(to_string(call));
    } else {
      line.add("crashed: ");
      line.add(signal_name(sig));
      line.add(" in the session process (not in a device call)");
    }
    line.add("\n");
    [[maybe_unused]] const ssize_t n = ::pwrite(g_fd, line.text, line.size, g_offset);
    // Zero force, if the device still can; a halt that hangs is cut short.
    struct sigaction alarm_action {};
    alarm_action.sa_handler = &on_alarm;
    sigemptyset(&alarm_action.sa_mask);
    ::sigaction(SIGALRM, &alarm_action, nullptr);
    ::alarm(1);
    // Waited for: an isolated plugin's host dies with this process
    // (PR_SET_PDEATHSIG), maybe before its halt thread reached the plugin.
    g_device->halt_and_wait(0.5);
    ::alarm(0);
  }
  // SA_RESETHAND restored the default action: die of the signal itself.
  ::raise(sig);
}

}  // namespace

CrashNote::CrashNote(db::SessionLock::CrashNoteTarget target, const HapticLoop& loop, Device& device) {
  if (target.fd < 0) return;
  if (g_armed.load()) throw std::logic_error("CrashNote: one is armed already");
  g_fd = target.fd;
  g_offset = target.offset;
  g_loop = &loop;
  g_device = &device;
  struct sigaction action {};
  action.sa_handler = &on_crash;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND | SA_NODEFER;
  g_armed.store(true);
  for (int i = 0; i < kNumSignals; ++i) ::sigaction(kSignals[i], &action, &g_previous[i]);
  armed_ = true;
}

CrashNote::~CrashNote() {
  if (!armed_) return;
  for (int i = 0; i < kNumSignals; ++i) ::sigaction(kSignals[i], &g_previous[i], nullptr);
  g_armed.store(false);
}

}  // namespace hapticlab::sessions
