#include "core/device/isolated_plugin_device.h"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "core/common/signal_name.h"
#include "core/device/plugin_device.h"
#include "core/common/clock.h"

extern char** environ;

namespace hapticlab {
namespace {

using Steady = std::chrono::steady_clock;

// How long the loop thread spins for an answer before it sleeps: a plugin
// that answers from memory (or the simulated one) is back within it; one
// waiting for its bus lets the loop thread's CPU go.
constexpr auto kParentSpin = std::chrono::microseconds(30);
// The longest futex sleep between two checks that the child still lives:
// a crash is noticed within this (a dead process wakes nobody).
constexpr auto kLivenessSlice = std::chrono::milliseconds(1);

std::string& registered_host() {
  static std::string path;
  return path;
}

// A status from the host, which is not trusted: one the ABI does not
// define counts as the call's failure status.
DeviceStatus from_host(std::int32_t status, DeviceStatus unknown) noexcept {
  if (status < 0 || status > static_cast<std::int32_t>(DeviceStatus::kTimeout)) return unknown;
  return static_cast<DeviceStatus>(status);
}

std::string bounded_text(const PluginCall& call) {
  const std::size_t n = std::min<std::size_t>(call.text_bytes, kPluginChannelTextBytes - 1);
  return std::string(call.text, ::strnlen(call.text, n));
}

std::timespec to_timespec(Steady::duration d) noexcept {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(d).count();
  return std::timespec{static_cast<std::time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
}

std::string format_ms(double ms) { return std::to_string(static_cast<long long>(std::llround(ms))); }

// The request for create: path, then key and value of each option, each
// ended by a NUL.
std::string create_request(const std::string& path, const std::map<std::string, std::string>& options) {
  std::string request = path;
  request.push_back('\0');
  for (const auto& [key, value] : options) {
    request += key;
    request.push_back('\0');
    request += value;
    request.push_back('\0');
  }
  if (request.size() >= kPluginChannelTextBytes)
    throw std::invalid_argument("plugin " + path + ": its path and options take " + std::to_string(request.size()) +
                                " bytes; at most " + std::to_string(kPluginChannelTextBytes - 1) +
                                " can be passed to an isolated plugin");
  return request;
}

// Starts the host process with the channel `memfd` as its
// kPluginHostChannelFd; returns posix_spawn's error (0: started, its id in
// `pid`).
int spawn_host(const std::string& host_executable, int memfd, pid_t& pid) {
  const std::string fd_text = std::to_string(kPluginHostChannelFd), parent_text = std::to_string(::getpid());
  // argv[0] "hapticlab": `ps` shows what it is, not /proc/self/exe.
  const char* argv[] = {"hapticlab", "device", "plugin-host", "--channel-fd", fd_text.c_str(),
                        "--parent-pid", parent_text.c_str(), nullptr};
  posix_spawn_file_actions_t files;
  posix_spawnattr_t attr;
  ::posix_spawn_file_actions_init(&files);
  ::posix_spawnattr_init(&attr);
  // stdin stays with the operator; stdout and stderr are shared, so what a
  // plugin prints reaches the terminal as before.
  ::posix_spawn_file_actions_addopen(&files, 0, "/dev/null", O_RDONLY, 0);
  ::posix_spawn_file_actions_adddup2(&files, memfd, kPluginHostChannelFd);
  // A process group of its own: Ctrl-C at the terminal is the session's to
  // handle (it stops the trial with zero force), not a crash of the plugin.
  sigset_t none, all;
  sigemptyset(&none);
  sigfillset(&all);
  sigdelset(&all, SIGKILL);
  sigdelset(&all, SIGSTOP);
  ::posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  ::posix_spawnattr_setpgroup(&attr, 0);
  ::posix_spawnattr_setsigmask(&attr, &none);
  ::posix_spawnattr_setsigdefault(&attr, &all);
  const int spawned = ::posix_spawn(&pid, host_executable.c_str(), &files, &attr, const_cast<char* const*>(argv),
                                    environ);
  ::posix_spawn_file_actions_destroy(&files);
  ::posix_spawnattr_destroy(&attr);
  return spawned;
}

}  // namespace

void set_plugin_host_executable(const std::string& path) { registered_host() = path; }
const std::string& plugin_host_executable() noexcept { return registered_host(); }

IsolatedPluginDevice::IsolatedPluginDevice(const std::string& host_executable, const std::string& path,
                                           const std::map<std::string, std::string>& options, const Bounds& bounds)
    : path_(path), bounds_(bounds) {
  const std::string request = create_request(path, options);

  // The channel.
  memfd_ = ::memfd_create("hapticlab-plugin-channel", MFD_CLOEXEC);
  if (memfd_ >= 0 && memfd_ == kPluginHostChannelFd) {
    // The child gets the channel as this very number, which dup2 would
    // leave close-on-exec: move it out of the way.
    const int moved = ::fcntl(memfd_, F_DUPFD_CLOEXEC, kPluginHostChannelFd + 1);
    ::close(memfd_);
    memfd_ = moved;
  }
  if (memfd_ < 0) fail_create(std::string("could not be isolated (memfd_create: ") + std::strerror(errno) + ")");
  if (::ftruncate(memfd_, sizeof(PluginChannel)) != 0)
    fail_create(std::string("could not be isolated (ftruncate: ") + std::strerror(errno) + ")");
  void* map = ::mmap(nullptr, sizeof(PluginChannel), PROT_READ | PROT_WRITE, MAP_SHARED, memfd_, 0);
  if (map == MAP_FAILED) fail_create(std::string("could not be isolated (mmap: ") + std::strerror(errno) + ")");
  channel_ = static_cast<PluginChannel*>(map);
  channel_->magic = kPluginChannelMagic;
  channel_->size = sizeof(PluginChannel);

  // The host: exec'd, not forked from this process (see the header).
  if (host_executable.empty())
    fail_create("could not be isolated: no host executable to run it in (only the hapticlab command has one; "
                "plugin-inprocess:PATH runs the plugin in this process)");
  const int spawned = spawn_host(host_executable, memfd_, pid_);
  if (spawned != 0) {
    pid_ = 0;
    fail_create("could not be isolated: its host " + host_executable + " did not start (" + std::strerror(spawned) +
                ")");
  }

  // Load and create in the host.
  PluginCall& c = channel_->call;
  std::memcpy(c.text, request.data(), request.size());
  c.text_bytes = static_cast<std::uint32_t>(request.size());
  c.instrument = static_cast<std::int32_t>(options.size());
  if (call(PluginCallOp::kCreate, bounds_.control_s) != DeviceStatus::kOk) {
    // Named by the loading step the host had reached.
    char stage[sizeof channel_->stage];
    std::memcpy(stage, channel_->stage, sizeof stage);
    stage[sizeof stage - 1] = '\0';
    fail_create<PluginProcessError>(process_end(stage[0] != '\0' ? stage : "load"));
  }
  const std::int32_t created = c.status;
  if (created != kPluginCreated) {
    const std::string message = bounded_text(c);
    call(PluginCallOp::kDestroy, bounds_.control_s);  // the host ends
    reap(1.0);
    ::munmap(channel_, sizeof(PluginChannel));
    ::close(memfd_);
    if (created == kPluginRejectedOptions) throw std::invalid_argument(message);
    throw std::runtime_error(message);
  }
  has_sim_ = c.result == 1;
  if (call(PluginCallOp::kName, bounds_.control_s) == DeviceStatus::kOk) {
    const std::string n = bounded_text(c);
    if (!n.empty()) name_ = n;
  }
}

template <typename E>
void IsolatedPluginDevice::fail_create(const std::string& what) {
  if (pid_ > 0) reap(0.0);
  if (channel_ != nullptr) ::munmap(channel_, sizeof(PluginChannel));
  if (memfd_ >= 0) ::close(memfd_);
  throw E("plugin " + path_ + " " + what);
}

std::string IsolatedPluginDevice::process_end(const std::string& where) const {
  switch (fault_.kind) {
    case FaultKind::kNone: return "";
    case FaultKind::kHung: {
      std::ostringstream bound;
      bound << fault_.bound_s;
      return "did not return from " + where + " within " + bound.str() + " s";
    }
    case FaultKind::kSignal: return "crashed (" + signal_name(fault_.code) + ") in " + where;
    case FaultKind::kExit: return "ended the process (exit status " + std::to_string(fault_.code) + ") in " + where;
  }
  return "";
}

std::string IsolatedPluginDevice::process_end() const { return process_end(to_string(fault_.op)); }

IsolatedPluginDevice::~IsolatedPluginDevice() {
  // The loop's clock may be gone already; nothing after the loop needs it.
  clock_ = nullptr;
  if (!dead_) {
    if (active_) call(PluginCallOp::kDeactivate, bounds_.deactivate_s);
    call(PluginCallOp::kDestroy, bounds_.control_s);
  }
  reap(1.0);
  ::munmap(channel_, sizeof(PluginChannel));
  ::close(memfd_);
}

void IsolatedPluginDevice::reap(double patience_s) noexcept {
  if (pid_ <= 0) return;
  const auto until = Steady::now() + std::chrono::duration_cast<Steady::duration>(
                                         std::chrono::duration<double>(patience_s));
  for (;;) {
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == pid_ || (r < 0 && errno != EINTR)) break;
    if (Steady::now() >= until) {
      ::kill(pid_, SIGKILL);
      while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
      }
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  pid_ = 0;
}

DeviceStatus IsolatedPluginDevice::fault_status() const noexcept {
  return fault_.kind == FaultKind::kHung ? DeviceStatus::kDeviceHung : DeviceStatus::kDeviceCrashed;
}

double IsolatedPluginDevice::loop_bound_s() const noexcept {
  if (clock_ == nullptr) return bounds_.control_s;
  return clock_->is_virtual() ? bounds_.loop_virtual_s : bounds_.loop_wall_s;
}

bool IsolatedPluginDevice::child_ended(PluginCallOp op, std::uint32_t seq) const noexcept {
  siginfo_t info{};
  if (::waitid(P_PID, static_cast<id_t>(pid_), &info, WEXITED | WNOHANG | WNOWAIT) != 0 || info.si_pid != pid_)
    return false;
  fault_.kind = info.si_code == CLD_EXITED ? FaultKind::kExit : FaultKind::kSignal;
  fault_.code = info.si_status;
  fault_.op = op;
  fault_.in_call = word(channel_->serving).load() == seq;
  dead_ = true;
  return true;
}

// Asks the host's halt thread for a halt and sleeps (futex, no spin: on a
// 2-core machine with the loop at SCHED_FIFO a spin could be what keeps the
// halt thread off a CPU) until it is done or max_wait_s passed.
// Async-signal-safe: atomics, clock_gettime and futex calls only.
void IsolatedPluginDevice::request_halt_and_wait(double max_wait_s) const noexcept {
  PluginChannel& ch = *channel_;
  const std::uint32_t asked = word(ch.halt).fetch_add(1) + 1;
  halt_asked_.store(asked, std::memory_order_release);
  futex_wake(ch.halt);
  wait_for_halt(asked, max_wait_s);
}

// Sleeps until the host's halt thread has passed halt number `asked` to the
// plugin, or max_wait_s passed. Async-signal-safe, as above.
void IsolatedPluginDevice::wait_for_halt(std::uint32_t asked, double max_wait_s) const noexcept {
  PluginChannel& ch = *channel_;
  const auto until =
      Steady::now() + std::chrono::duration_cast<Steady::duration>(std::chrono::duration<double>(max_wait_s));
  for (;;) {
    const std::uint32_t done = word(ch.halts_done).load();
    if (static_cast<std::int32_t>(done - asked) >= 0) break;
    const auto left = until - Steady::now();
    if (left <= Steady::duration::zero()) break;
    const auto left_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(left).count();
    const std::timespec ts{static_cast<std::time_t>(left_ns / 1'000'000'000), static_cast<long>(left_ns % 1'000'000'000)};
    futex_wait(ch.halts_done, done, &ts);
  }
}

void IsolatedPluginDevice::kill_hung(PluginCallOp op, double waited_ms, double bound_s) const noexcept {
  // Force off first, as the watchdog would: the host's halt thread still
  // runs while its main thread hangs in the plugin.
  request_halt_and_wait(bounds_.halt_grace_s);
  ::kill(pid_, SIGKILL);
  fault_ = Fault{FaultKind::kHung, op, 0, true, waited_ms, bound_s};
  dead_ = true;
}

DeviceStatus IsolatedPluginDevice::call(PluginCallOp op, double bound_s) const noexcept {
  if (dead_) return fault_status();
  PluginChannel& ch = *channel_;
  ch.call.op = op;
  ch.call.now_s = clock_ != nullptr ? clock_->now_s() : 0.0;
  const Steady::time_point start = Steady::now();
  ch.call.sent_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(start.time_since_epoch()).count();
  const std::uint32_t seq = ++seq_;
  word(ch.request).store(seq);
  if (word(ch.host_sleeping).load() != 0) futex_wake(ch.request);

  // Spin first: an answer within microseconds needs no system call.
  const Steady::time_point spin_until = start + kParentSpin;
  for (int k = 0;; ++k) {
    if (word(ch.reply).load(std::memory_order_acquire) == seq) return DeviceStatus::kOk;
    if ((k & 63) == 63 && Steady::now() > spin_until) break;
    cpu_relax();
  }
  // Then sleep, in slices: a process that died wakes nobody.
  const Steady::time_point deadline =
      start + std::chrono::duration_cast<Steady::duration>(std::chrono::duration<double>(bound_s));
  for (;;) {
    word(ch.parent_sleeping).store(1);
    const std::uint32_t seen = word(ch.reply).load();
    if (seen == seq) {
      word(ch.parent_sleeping).store(0);
      return DeviceStatus::kOk;
    }
    const Steady::time_point now = Steady::now();
    const std::timespec slice = to_timespec(std::clamp<Steady::duration>(deadline - now, Steady::duration::zero(),
                                                                        kLivenessSlice));
    const bool woken = now < deadline && futex_wait(ch.reply, seen, &slice);
    word(ch.parent_sleeping).store(0);
    if (word(ch.reply).load(std::memory_order_acquire) == seq) return DeviceStatus::kOk;
    if (woken) continue;
    if (child_ended(op, seq)) return fault_status();
    const Steady::time_point after = Steady::now();
    if (after >= deadline) {
      kill_hung(op, std::chrono::duration<double, std::milli>(after - start).count(), bound_s);
      return fault_status();
    }
  }
}

DeviceStatus IsolatedPluginDevice::configure(const DeviceConfig& config) {
  configure_error_.clear();
  if (active_) return DeviceStatus::kInvalidConfig;
  channel_->call.rate_Hz = config.nominal_rate_Hz;
  channel_->call.seed = config.seed;
  if (const DeviceStatus s = call(PluginCallOp::kConfigure, bounds_.control_s); s != DeviceStatus::kOk) {
    configure_error_ = "plugin " + path_ + ": " + fault_detail();
    return s;
  }
  const PluginCall& c = channel_->call;
  const DeviceStatus status = answer(DeviceStatus::kInvalidConfig);
  if (status != DeviceStatus::kOk) {
    configure_error_ = bounded_text(c);
    if (configure_error_.empty())
      configure_error_ = "plugin " + path_ + " refused its configuration (" + to_string(status) + ")";
    return status;
  }
  // Checked in the host already; checked again here, where they are used.
  const DeviceRatings ratings = c.ratings;
  configure_error_ = check_ratings("plugin " + path_, ratings);
  if (!configure_error_.empty()) return DeviceStatus::kInvalidConfig;
  ratings_ = ratings;
  return DeviceStatus::kOk;
}

DeviceStatus IsolatedPluginDevice::activate(const Clock& clock) {
  if (active_) return DeviceStatus::kOk;
  clock_ = &clock;
  if (const DeviceStatus s = call(PluginCallOp::kActivate, bounds_.control_s); s != DeviceStatus::kOk) return s;
  const DeviceStatus status = answer(DeviceStatus::kInvalidConfig);
  active_ = status == DeviceStatus::kOk;
  return status;
}

DeviceStatus IsolatedPluginDevice::read(DeviceReading& reading) noexcept {
  if (!sched_copied_ && !dead_) {
    // The host serves the loop: it gets the loop thread's real-time
    // policy and priority, if any (`--realtime`), once.
    sched_copied_ = true;
    const int policy = ::sched_getscheduler(0);
    sched_param param{};
    if ((policy == SCHED_FIFO || policy == SCHED_RR) && ::sched_getparam(0, &param) == 0) {
      ::sched_setscheduler(pid_, policy, &param);
      // Its halt thread one above, so a plugin call spinning at the loop's
      // priority cannot keep a halt from reaching the plugin.
      const std::int32_t halt_tid = std::atomic_ref<std::int32_t>(channel_->halt_tid).load();
      sched_param above = param;
      above.sched_priority = std::min(param.sched_priority + 1, ::sched_get_priority_max(policy));
      if (halt_tid > 0) ::sched_setscheduler(halt_tid, policy, &above);
    }
  }
  if (const DeviceStatus s = call(PluginCallOp::kRead, loop_bound_s()); s != DeviceStatus::kOk) return s;
  const PluginCall& c = channel_->call;
  const DeviceStatus status = answer(DeviceStatus::kReadFailed);
  if (status != DeviceStatus::kOk) return status;
  bool finite = true;
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t j = 0; j < kNumDeviceJoints; ++j) {
      const double x = c.reading.position[i][j];
      finite = finite && std::isfinite(x);
      reading.position[i][j] = x;
    }
  reading.device_time_s = c.reading.device_time_s;
  return finite ? DeviceStatus::kOk : DeviceStatus::kNonFiniteReading;
}

DeviceStatus IsolatedPluginDevice::write(const DeviceCommand& command) noexcept {
  DeviceCommand& out = channel_->call.command;
  bool finite = true;
  for (std::size_t i = 0; i < 2; ++i)
    for (std::size_t j = 0; j < kNumDeviceJoints; ++j) {
      const double f = command.force[i][j];
      const double peak = ratings_.joint[i][j].peak_force;
      finite = finite && std::isfinite(f);
      out.force[i][j] = std::clamp(f, -peak, peak);
    }
  // A non-finite value never reaches a motor: zero force instead.
  if (!finite) out = DeviceCommand{};
  if (const DeviceStatus s = call(PluginCallOp::kWrite, loop_bound_s()); s != DeviceStatus::kOk) return s;
  if (!finite) return DeviceStatus::kWriteFailed;
  return answer(DeviceStatus::kWriteFailed);
}

DeviceStatus IsolatedPluginDevice::deactivate() noexcept {
  active_ = false;
  const DeviceStatus s = call(PluginCallOp::kDeactivate, bounds_.deactivate_s);
  clock_ = nullptr;
  if (s != DeviceStatus::kOk) return s;
  return answer(DeviceStatus::kWriteFailed);
}

void IsolatedPluginDevice::halt() noexcept {
  // Any thread, also while the loop thread waits for a read: the host's
  // halt thread takes it. Harmless if the host is gone.
  halt_asked_.store(word(channel_->halt).fetch_add(1) + 1, std::memory_order_release);
  futex_wake(channel_->halt);
}

bool IsolatedPluginDevice::halt_unconfirmed() const noexcept {
  const std::uint32_t asked = halt_asked_.load(std::memory_order_acquire);
  if (asked == 0) return false;
  // The host's halt thread stores the last value it passed to the plugin. A
  // live host on a loaded machine may take a few ms to be scheduled: not an
  // unconfirmed halt, so it is given kHaltConfirmWait_s before the answer.
  const auto done = [&] { return static_cast<std::int32_t>(word(channel_->halts_done).load() - asked) >= 0; };
  if (done()) return false;
  wait_for_halt(asked, kHaltConfirmWait_s);
  return !done();
}

void IsolatedPluginDevice::halt_and_wait(double max_wait_s) noexcept {
  if (dead_) return;  // the host is gone: nothing to wait for
  request_halt_and_wait(max_wait_s);
}

DeviceStatus IsolatedPluginDevice::answer(DeviceStatus unknown) const noexcept {
  const PluginCall& c = channel_->call;
  // The host's PluginDevice keeps the first failure since the trial's
  // activate(); mirrored here for status_detail(), which may be asked from
  // another thread.
  unknown_code_.store(c.unknown_code, std::memory_order_relaxed);
  unknown_op_.store(c.unknown_op, std::memory_order_relaxed);
  return from_host(c.status, unknown);
}

std::string IsolatedPluginDevice::status_detail() const {
  return describe_unknown_status({unknown_op_.load(std::memory_order_relaxed),
                                  unknown_code_.load(std::memory_order_relaxed)});
}

std::string IsolatedPluginDevice::fault_detail() const {
  const std::string op = to_string(fault_.op);
  switch (fault_.kind) {
    case FaultKind::kNone: return "";
    case FaultKind::kHung: return "device " + op + " hung for " + format_ms(fault_.waited_ms) + " ms";
    case FaultKind::kSignal:
    case FaultKind::kExit: {
      const std::string how = fault_.kind == FaultKind::kSignal
                                  ? signal_name(fault_.code)
                                  : "exit status " + std::to_string(fault_.code);
      return "device_crashed: " + how + (fault_.in_call ? " in " + op : " between calls, found at " + op);
    }
  }
  return "";
}

bool IsolatedPluginDevice::set_start_pose(int instrument, const DeviceJoints& position) noexcept {
  if (!has_sim_) return false;
  channel_->call.instrument = instrument;
  channel_->call.joints = position;
  return call(PluginCallOp::kSetStartPose, active_ ? loop_bound_s() : bounds_.control_s) == DeviceStatus::kOk &&
         channel_->call.result == 1;
}

void IsolatedPluginDevice::set_hand(int instrument, const HandCouplings& hand) noexcept {
  if (!has_sim_) return;
  channel_->call.instrument = instrument;
  channel_->call.hand = hand;
  call(PluginCallOp::kSetHand, loop_bound_s());
}

DeviceJoints IsolatedPluginDevice::hand_force(int instrument) const noexcept {
  if (!has_sim_) return {};
  channel_->call.instrument = instrument;
  if (call(PluginCallOp::kHandForce, loop_bound_s()) != DeviceStatus::kOk) return {};
  return channel_->call.joints;
}

DeviceJoints IsolatedPluginDevice::motor_force(int instrument) const noexcept {
  if (!has_sim_) return {};
  channel_->call.instrument = instrument;
  if (call(PluginCallOp::kMotorForce, loop_bound_s()) != DeviceStatus::kOk) return {};
  return channel_->call.joints;
}

}  // namespace hapticlab
