#include "core/loop/realtime.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace hapticlab {
namespace {

int cpu_count() noexcept {
  const long n = sysconf(_SC_NPROCESSORS_ONLN);
  return n > 0 ? static_cast<int>(n) : 1;
}

}  // namespace

RealtimeResult apply_realtime_to_this_thread(const RealtimeOptions& options) noexcept {
  RealtimeResult result;
  if (!options.enabled) return result;
  sched_param param{};
  param.sched_priority = options.priority;
  // pthread_* return the error instead of setting errno.
  result.sched_errno = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  result.scheduled = result.sched_errno == 0;
  result.cpu = options.cpu >= 0 ? options.cpu : cpu_count() - 1;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(result.cpu, &set);
  result.affinity_errno = pthread_setaffinity_np(pthread_self(), sizeof set, &set);
  result.pinned = result.affinity_errno == 0;
  return result;
}

std::string lock_process_memory() {
  if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) return {};
  return std::strerror(errno);
}

std::string prepare_realtime(const RealtimeOptions& options, RealtimeResult* granted) {
  if (options.priority < 1 || options.priority > 99)
    throw std::invalid_argument("realtime-priority: " + std::to_string(options.priority) + " is outside 1..99");
  if (options.cpu < -1 || options.cpu >= cpu_count())
    throw std::invalid_argument("realtime-cpu: " + std::to_string(options.cpu) + " is outside 0.." +
                                std::to_string(cpu_count() - 1) + " (this machine's CPUs), or -1 for the last");
  const std::string locked = lock_process_memory();
  RealtimeResult r;
  std::thread([&] { r = apply_realtime_to_this_thread(options); }).join();
  if (granted != nullptr) *granted = r;

  std::string line = "real-time: ";
  if (r.scheduled) {
    line += "SCHED_FIFO priority " + std::to_string(options.priority);
  } else {
    line += "SCHED_FIFO refused (" + std::string(std::strerror(r.sched_errno)) +
            "; it needs root, CAP_SYS_NICE or an rtprio limit, see docs/devices.md), normal scheduling";
  }
  line += r.pinned ? ", on CPU " + std::to_string(r.cpu)
                   : ", not pinned (" + std::string(std::strerror(r.affinity_errno)) + ")";
  line += locked.empty() ? ", memory locked" : ", memory not locked (" + locked + ": raise ulimit -l)";
  return line;
}

}  // namespace hapticlab
