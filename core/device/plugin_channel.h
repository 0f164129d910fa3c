#pragma once
// PluginChannel: the shared memory between HapticLab and the process that
// hosts an isolated device plugin (IsolatedPluginDevice on one side,
// run_plugin_host() on the other). It lives in a memfd both map.
//
// One call at a time. The parent fills `call` and advances `request`; the
// host serves it, puts the answer into `call` and sets `reply` to the same
// number. Each side spins for a few microseconds, then sleeps on the
// other's word with a futex (shared between processes). A `*_sleeping`
// flag says whether a wake-up is needed, so a call answered within the
// spin costs no system call. Both flags follow the same order (flag, then
// re-check the word, then sleep; word, then check the flag, then wake), all
// sequentially consistent, so no wake-up is lost.
//
// halt() has a word of its own: the parent advances `halt` from any thread,
// and a thread of the host waits on it and calls the plugin's halt() at
// once, concurrently with whatever the host's main thread is doing (a read
// that hangs, say), as hapticlab/device_plugin.h allows.
//
// The host is not trusted: everything it writes is read as untrusted input
// (statuses range-checked, readings checked for NaN, text bounded).

#include <atomic>
#include <cstdint>
#include <ctime>
#include <type_traits>

#include "core/device/device.h"
#include "core/device/hand_attachment.h"

namespace hapticlab {

inline constexpr std::uint32_t kPluginChannelMagic = 0x43504c48;  // "HLPC"
inline constexpr std::size_t kPluginChannelTextBytes = 16384;
// The fd number the host finds the channel on (`hapticlab device plugin-host`).
inline constexpr int kPluginHostChannelFd = 3;
// In `halt`: the host's own request that its halt thread end (at destroy).
inline constexpr std::uint32_t kPluginHaltQuitBit = 0x80000000u;

enum class PluginCallOp : std::uint32_t {
  kNone = 0,
  kCreate,        // in: text = path, then key, value pairs (NUL-separated), instrument = pair count
  kConfigure,     // in: rate_Hz, seed; out: status, ratings, text = configure error
  kActivate,      // out: status
  kRead,          // out: status, reading
  kWrite,         // in: command; out: status
  kDeactivate,    // out: status
  kName,          // out: text
  kSetStartPose,  // in: instrument, joints; out: result (1 taken)
  kSetHand,       // in: instrument, hand
  kHandForce,     // in: instrument; out: joints
  kMotorForce,    // in: instrument; out: joints
  kDestroy,       // the host destroys the device, answers and exits
};
// "read", "write", ... as the operator reads it in a fault's reason.
const char* to_string(PluginCallOp op) noexcept;

// kCreate's answer in `status`.
enum PluginCreateResult : std::int32_t { kPluginCreated = 0, kPluginRefused = 1, kPluginRejectedOptions = 2 };

struct PluginCall {
  PluginCallOp op;
  std::int32_t instrument;
  // The loop clock's time when the call was made [s]: the plugin's clock
  // callback returns it during the call.
  double now_s;
  // When the parent sent the call [ns of std::chrono::steady_clock]: the
  // host foresees the loop's next read from these.
  std::int64_t sent_ns;
  double rate_Hz;
  std::uint64_t seed;
  DeviceReading reading;
  DeviceCommand command;
  DeviceRatings ratings;
  HandCouplings hand;
  DeviceJoints joints;
  std::int32_t status;  // the answer: a DeviceStatus, or a PluginCreateResult
  // The plugin's last status code outside the ABI and its call, as the
  // host's PluginDevice::unknown_status() gives them (op 0: none yet).
  std::int32_t unknown_op;
  std::int32_t unknown_code;
  std::int32_t result;  // kSetStartPose: 1 taken; kCreate: 1 with the simulation extension
  std::uint32_t text_bytes;
  char text[kPluginChannelTextBytes];
};

struct PluginChannel {
  std::uint32_t magic;  // kPluginChannelMagic, written by the parent
  std::uint32_t size;   // sizeof(PluginChannel): the same build on both sides
  alignas(64) std::uint32_t request;  // parent: the number of the call in `call`
  std::uint32_t host_sleeping;        // host: asleep on `request` (or about to be)
  alignas(64) std::uint32_t reply;    // host: the number of the call answered
  std::uint32_t parent_sleeping;      // parent: asleep on `reply` (or about to be)
  std::uint32_t serving;              // host: the call it has begun (to tell "in read" from "between calls")
  alignas(64) std::uint32_t halt;     // parent: halts asked for; the host's halt thread waits on it
  std::uint32_t halts_done;           // host: the last `halt` value passed to the plugin (woken on change)
  std::int32_t halt_tid;              // host: its halt thread's kernel thread id, for the parent to schedule
  char stage[32];                     // host: the loading step under way during kCreate ("load", "create")
  alignas(64) PluginCall call;
};
static_assert(std::is_trivially_copyable_v<PluginChannel>, "lives in shared memory");
static_assert(std::atomic_ref<std::uint32_t>::is_always_lock_free, "futex words across processes");

// The words are accessed through std::atomic_ref; the futex calls are
// shared (no FUTEX_PRIVATE_FLAG), as the two sides are different processes.
inline std::atomic_ref<std::uint32_t> word(std::uint32_t& w) noexcept { return std::atomic_ref<std::uint32_t>(w); }
// Sleeps while *w == expected, at most `timeout` (nullptr: no limit).
// Returns false when the time ran out, true otherwise (woken, value
// changed, interrupted: the caller re-checks in every case).
bool futex_wait(std::uint32_t& w, std::uint32_t expected, const std::timespec* timeout) noexcept;
void futex_wake(std::uint32_t& w) noexcept;
// One pause of a spin loop (x86 PAUSE, ARM YIELD).
void cpu_relax() noexcept;

}  // namespace hapticlab
