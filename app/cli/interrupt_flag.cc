#include "app/cli/interrupt_flag.h"

#include <csignal>
#include <ctime>

namespace hapticlab::app {
namespace {

std::atomic<bool> g_raised{false};
std::atomic<double> g_first_s{0.0};

double monotonic_s() noexcept {  // clock_gettime is async-signal-safe
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}
struct sigaction g_old_int {};
struct sigaction g_old_term {};

extern "C" void on_signal(int signal_number) {
  if (!g_raised.exchange(true)) {
    g_first_s = monotonic_s();
    return;
  }
  // One Ctrl-C can arrive twice (`timeout` signals the child and then its
  // process group): only a second signal a second later means "now".
  if (monotonic_s() - g_first_s.load() < 1.0) return;
  std::signal(signal_number, SIG_DFL);
  std::raise(signal_number);
}

}  // namespace

InterruptFlag::InterruptFlag() {
  g_raised = false;
  struct sigaction action {};
  action.sa_handler = on_signal;
  action.sa_flags = SA_RESTART;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &g_old_int);
  sigaction(SIGTERM, &action, &g_old_term);
}

InterruptFlag::~InterruptFlag() {
  sigaction(SIGINT, &g_old_int, nullptr);
  sigaction(SIGTERM, &g_old_term, nullptr);
}

const std::atomic<bool>& InterruptFlag::flag() const noexcept { return g_raised; }

}  // namespace hapticlab::app
