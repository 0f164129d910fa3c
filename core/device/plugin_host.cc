#include "core/device/plugin_host.h"


#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include "core/device/plugin_channel.h"
#include "core/device/plugin_device.h"
#include "core/common/clock.h"

namespace hapticlab {
namespace {

using SteadyClock = std::chrono::steady_clock;

// How long the host spins for the next call before it sleeps. The loop's
// write follows its read within the engine's and the VE's step (a few to
// some tens of µs), and on the virtual clock every call follows the last
// at once: the spin catches those without a wake-up.
constexpr auto kHostSpin = std::chrono::microseconds(50);
// The loop's next read: the host wakes this long before it is due, and
// spins until this long after (a late loop), then sleeps until it comes.
// Periods longer than the last bound (a loop below 100 Hz, a paused one)
// are not anticipated.
constexpr auto kWakeBeforeRead = std::chrono::microseconds(200);
constexpr auto kSpinAfterDue = std::chrono::microseconds(300);
constexpr auto kLongestAnticipatedPeriod = std::chrono::milliseconds(10);

// The loop's clock as the parent sent it with the call being served.
class ChannelClock final : public Clock {
 public:
  explicit ChannelClock(const PluginCall& call) noexcept : call_(call) {}
  double now_s() const noexcept override { return call_.now_s; }
  // Only read: the parent's loop does the waiting.
  void sleep_until(double) noexcept override {}
  bool is_virtual() const noexcept override { return false; }

 private:
  const PluginCall& call_;
};

void put_text(PluginCall& call, const std::string& text) noexcept {
  const std::size_t n = std::min(text.size(), kPluginChannelTextBytes - 1);
  std::memcpy(call.text, text.data(), n);
  call.text[n] = '\0';
  call.text_bytes = static_cast<std::uint32_t>(n);
}

void put_stage(void* context, const char* stage) {
  char* out = static_cast<char*>(context);
  std::snprintf(out, sizeof PluginChannel::stage, "%s", stage);
}

// Passes each halt the parent asks for after `seen` to the plugin, until
// the quit bit.
void serve_halts(PluginChannel& ch, PluginDevice& device, std::uint32_t seen) {
  // The parent gives this thread a real-time priority above the host's
  // main thread (IsolatedPluginDevice::read), so a plugin call that spins
  // at that priority cannot keep a halt from the plugin.
  std::atomic_ref<std::int32_t>(ch.halt_tid).store(static_cast<std::int32_t>(::syscall(SYS_gettid)));
  for (;;) {
    const std::uint32_t now = word(ch.halt).load();
    if ((now & kPluginHaltQuitBit) != 0) {
      // A halt asked for before the device is destroyed still reaches it.
      if ((now & ~kPluginHaltQuitBit) != seen) device.halt();
      return;
    }
    if (now != seen) {
      seen = now;
      device.halt();
      word(ch.halts_done).store(now);
      futex_wake(ch.halts_done);
      continue;
    }
    futex_wait(ch.halt, now, nullptr);
  }
}

class Host {
 public:
  explicit Host(PluginChannel& ch) : ch_(ch), clock_(ch.call) {}
  ~Host() { stop_halts(); }

  // Serves calls until kDestroy has been answered.
  void run() {
    // The last call answered, not the last asked: the parent may have
    // sent its first call before this process got here.
    std::uint32_t last = word(ch_.reply).load();
    for (;;) {
      const std::uint32_t seq = wait_for_call(last);
      last = seq;
      word(ch_.serving).store(seq);
      if (ch_.call.op == PluginCallOp::kRead) note_read(ch_.call.sent_ns);
      const bool done = serve(ch_.call);
      word(ch_.reply).store(seq);
      if (word(ch_.parent_sleeping).load() != 0) futex_wake(ch_.reply);
      if (done) return;
    }
  }

 private:
  // Spins until the call after `last` arrives or `until` passes; the
  // call's number, or `last`.
  std::uint32_t spin_for_call(std::uint32_t last, SteadyClock::time_point until) const noexcept {
    for (int k = 0;; ++k) {
      const std::uint32_t seq = word(ch_.request).load(std::memory_order_acquire);
      if (seq != last || ((k & 63) == 63 && SteadyClock::now() > until)) return seq;
      cpu_relax();
    }
  }

  // Sleeps until the call after `last` arrives, or at most `timeout`.
  std::uint32_t sleep_for_call(std::uint32_t last, const std::timespec* timeout) noexcept {
    word(ch_.host_sleeping).store(1);
    std::uint32_t seq = word(ch_.request).load();
    if (seq == last) {
      futex_wait(ch_.request, last, timeout);
      seq = word(ch_.request).load(std::memory_order_acquire);
    }
    word(ch_.host_sleeping).store(0);
    return seq;
  }

  std::uint32_t wait_for_call(std::uint32_t last) {
    const SteadyClock::time_point now = SteadyClock::now();
    std::uint32_t seq = spin_for_call(last, now + kHostSpin);
    if (seq != last) return seq;
    // The loop's next read is due one period after the last: sleep until
    // shortly before it, then spin across it. An OS wake-up on a loaded
    // machine comes late by up to some hundred µs (the loop's own clock
    // spins its last 150 µs for the same reason), which would otherwise
    // be added to every read.
    if (next_read_due_ > now) {
      const SteadyClock::duration to_wake = next_read_due_ - kWakeBeforeRead - SteadyClock::now();
      if (to_wake > SteadyClock::duration::zero()) {
        const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(to_wake).count();
        const std::timespec t{static_cast<std::time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
        seq = sleep_for_call(last, &t);
        if (seq != last) return seq;
      }
      seq = spin_for_call(last, next_read_due_ + kSpinAfterDue);
      if (seq != last) return seq;
    }
    for (;;) {
      seq = sleep_for_call(last, nullptr);
      if (seq != last) return seq;
    }
  }

  // From the times the parent sent its reads: when the next one is due.
  void note_read(std::int64_t sent_ns) noexcept {
    const SteadyClock::time_point sent{std::chrono::nanoseconds(sent_ns)};
    const SteadyClock::duration period = sent - last_read_sent_;
    last_read_sent_ = sent;
    next_read_due_ = period > SteadyClock::duration::zero() && period < kLongestAnticipatedPeriod
                         ? sent + period
                         : SteadyClock::time_point{};
  }

  // Returns true after kDestroy.
  bool serve(PluginCall& call) {
    if (call.op == PluginCallOp::kCreate) {
      create(call);
      return false;
    }
    if (!device_) {
      call.status = static_cast<std::int32_t>(DeviceStatus::kNotConfigured);
      return call.op == PluginCallOp::kDestroy;
    }
    const auto instrument = call.instrument;
    switch (call.op) {
      case PluginCallOp::kConfigure: {
        const DeviceStatus status = device_->configure(DeviceConfig{call.rate_Hz, call.seed});
        call.status = static_cast<std::int32_t>(status);
        if (status == DeviceStatus::kOk) call.ratings = device_->ratings();
        put_text(call, device_->configure_error());
        break;
      }
      case PluginCallOp::kActivate: call.status = static_cast<std::int32_t>(device_->activate(clock_)); break;
      case PluginCallOp::kRead: call.status = static_cast<std::int32_t>(device_->read(call.reading)); break;
      case PluginCallOp::kWrite: call.status = static_cast<std::int32_t>(device_->write(call.command)); break;
      case PluginCallOp::kDeactivate: call.status = static_cast<std::int32_t>(device_->deactivate()); break;
      case PluginCallOp::kName: put_text(call, device_->name()); break;
      case PluginCallOp::kSetStartPose:
        call.result = device_->set_start_pose(instrument, call.joints) ? 1 : 0;
        break;
      case PluginCallOp::kSetHand: device_->set_hand(instrument, call.hand); break;
      case PluginCallOp::kHandForce: call.joints = device_->hand_force(instrument); break;
      case PluginCallOp::kMotorForce: call.joints = device_->motor_force(instrument); break;
      case PluginCallOp::kDestroy:
        stop_halts();
        device_.reset();
        call.status = static_cast<std::int32_t>(DeviceStatus::kOk);
        return true;
      default: call.status = static_cast<std::int32_t>(DeviceStatus::kInvalidConfig); break;
    }
    const PluginDevice::UnknownStatus unknown = device_->unknown_status();
    call.unknown_op = unknown.op;
    call.unknown_code = unknown.code;
    return false;
  }

  void create(PluginCall& call) {
    // path, then key and value of each option, NUL-separated.
    call.text[kPluginChannelTextBytes - 1] = '\0';
    const char* p = call.text;
    const char* end = call.text + std::min<std::size_t>(call.text_bytes, kPluginChannelTextBytes - 1);
    const auto next = [&] {
      std::string s(p);
      p = std::min(end, p + s.size() + 1);
      return s;
    };
    const std::string path = next();
    std::map<std::string, std::string> options;
    for (std::int32_t i = 0; i < call.instrument && p < end; ++i) {
      std::string key = next();
      options[key] = next();
    }
    try {
      device_ = std::make_unique<PluginDevice>(path, options, &put_stage, ch_.stage);
      call.status = kPluginCreated;
      call.result = device_->hand_attachment() != nullptr ? 1 : 0;
      // Every halt from the answer on counts, also one that comes before
      // the thread gets to run.
      const std::uint32_t before = word(ch_.halt).load();
      halts_ = std::thread([this, before] { serve_halts(ch_, *device_, before); });
    } catch (const std::invalid_argument& e) {
      call.status = kPluginRejectedOptions;
      put_text(call, e.what());
    } catch (const std::exception& e) {
      call.status = kPluginRefused;
      put_text(call, e.what());
    }
  }

  void stop_halts() {
    if (!halts_.joinable()) return;
    word(ch_.halt).fetch_or(kPluginHaltQuitBit);
    futex_wake(ch_.halt);
    halts_.join();
  }

  PluginChannel& ch_;
  ChannelClock clock_;
  SteadyClock::time_point last_read_sent_{};
  SteadyClock::time_point next_read_due_{};
  std::unique_ptr<PluginDevice> device_;
  std::thread halts_;
};

}  // namespace

int run_plugin_host(int channel_fd, pid_t parent_pid) {
  // Die with the parent; and if it is gone already, do not start.
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != parent_pid) {
    std::fprintf(stderr, "hapticlab device plugin-host: process %d is not this process's parent\n",
                 static_cast<int>(parent_pid));
    return 2;
  }
  // A crash must end this process by its signal, so the parent can name
  // it; a sanitizer's handler would turn it into an exit status.
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGTRAP, SIGSYS}) std::signal(sig, SIG_DFL);
  // Nothing of the parent's but the channel: no database, lock or socket
  // stays open in here (close_range: Linux 5.9).
  if (channel_fd > 3) ::close_range(3, static_cast<unsigned>(channel_fd) - 1, 0);
  ::close_range(static_cast<unsigned>(channel_fd) + 1, UINT_MAX, 0);

  struct stat st{};
  if (::fstat(channel_fd, &st) != 0 || static_cast<std::size_t>(st.st_size) < sizeof(PluginChannel)) {
    std::fprintf(stderr, "hapticlab device plugin-host: fd %d is not a plugin channel\n", channel_fd);
    return 2;
  }
  void* map = ::mmap(nullptr, sizeof(PluginChannel), PROT_READ | PROT_WRITE, MAP_SHARED, channel_fd, 0);
  if (map == MAP_FAILED) {
    std::fprintf(stderr, "hapticlab device plugin-host: cannot map fd %d: %s\n", channel_fd, std::strerror(errno));
    return 2;
  }
  ::close(channel_fd);
  auto& ch = *static_cast<PluginChannel*>(map);
  if (ch.magic != kPluginChannelMagic || ch.size != sizeof(PluginChannel)) {
    std::fprintf(stderr, "hapticlab device plugin-host: the channel is of another build (size %u, this one %zu)\n",
                 ch.size, sizeof(PluginChannel));
    return 2;
  }
  {
    Host host(ch);
    host.run();
  }
  // Not through exit(): the parent's and the plugin's static destructors
  // have nothing left to do, and the parent is waiting.
  std::fflush(nullptr);
  ::_exit(0);
}

}  // namespace hapticlab
