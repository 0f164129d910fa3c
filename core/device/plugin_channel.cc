#include "core/device/plugin_channel.h"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>

namespace hapticlab {

const char* to_string(PluginCallOp op) noexcept {
  switch (op) {
    case PluginCallOp::kNone: return "none";
    case PluginCallOp::kCreate: return "create";
    case PluginCallOp::kConfigure: return "configure";
    case PluginCallOp::kActivate: return "activate";
    case PluginCallOp::kRead: return "read";
    case PluginCallOp::kWrite: return "write";
    case PluginCallOp::kDeactivate: return "deactivate";
    case PluginCallOp::kName: return "name";
    case PluginCallOp::kSetStartPose: return "set_start_pose";
    case PluginCallOp::kSetHand: return "set_hand";
    case PluginCallOp::kHandForce: return "hand_force";
    case PluginCallOp::kMotorForce: return "motor_force";
    case PluginCallOp::kDestroy: return "destroy";
  }
  return "unknown call";
}

bool futex_wait(std::uint32_t& w, std::uint32_t expected, const std::timespec* timeout) noexcept {
  const long r = ::syscall(SYS_futex, &w, FUTEX_WAIT, expected, timeout, nullptr, 0);
  return !(r != 0 && errno == ETIMEDOUT);
}

void futex_wake(std::uint32_t& w) noexcept { ::syscall(SYS_futex, &w, FUTEX_WAKE, 1, nullptr, nullptr, 0); }

void cpu_relax() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#elif defined(__aarch64__)
  asm volatile("yield");
#endif
}

}  // namespace hapticlab
