#pragma once
// IsolatedPluginDevice, the default "plugin:PATH" backend: a device plugin
// run in a child process that HapticLab supervises, so that a plugin that
// crashes or hangs ends the trial with a named reason instead of taking the
// session down with it.
//
// The child is a host process (`hapticlab device plugin-host`, started with
// posix_spawn: the session process has threads, and a fork of it could
// inherit a lock another thread held) that loads the plugin with the same
// loader and checks as PluginDevice (plugin_host.h). Every call crosses a
// shared-memory channel (plugin_channel.h) with the loop clock's time, which
// the plugin's clock callback returns. On the loop thread a call spins
// briefly, then sleeps on a futex with a deadline: no allocation, lock or
// exception.
//
// Faults of the process (the other faults are the plugin's own statuses):
//   - the child dies during a call (a signal, an exit): the call returns
//     kDeviceCrashed and fault_detail() is "device_crashed: SIGSEGV in read"
//     ("... between calls, found at read" when it died while idle);
//   - the child does not answer within the call's bound: it is asked to halt
//     (the plugin's halt() runs on the host's halt thread), given
//     Bounds::halt_grace_s for it, and killed; the call returns kDeviceHung
//     and fault_detail() is "device read hung for 20 ms".
// From then on every call returns that status at once and nothing more is
// sent to the child. The loop then ends with zero force commanded (its own
// path), and the session runner records fault_detail() as the reason.
//
// Threads as for Device; halt() from any thread, concurrently with the
// rest. The child is tied to the thread that constructs the device
// (PR_SET_PDEATHSIG acts when that thread ends): construct and destroy it
// on the thread that runs the session. Not copyable or movable, as
// PluginDevice.

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>

#include "core/device/device.h"
#include "core/device/hand_attachment.h"
#include "core/device/plugin_channel.h"

namespace hapticlab {

class Clock;

// The constructor's error when the host process crashed, exited or hung
// while loading or creating the plugin ("plugin PATH crashed (SIGSEGV) in
// create"), as opposed to a refusal by the loader or the plugin.
class PluginProcessError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class IsolatedPluginDevice final : public Device, public HandAttachment {
 public:
  // How long each call may take before the child is killed.
  struct Bounds {
    // Loop-thread calls (read, write, the simulation extension) on the wall
    // clock [s]: below the loop's 20 ms watchdog (LoopSafetyConfig), so the
    // hang is named before the watchdog halts the device without a name.
    double loop_wall_s = 0.015;
    // The same on the virtual clock [s]: nothing waits on it in real time,
    // but a plugin that hangs must not stall a simulated session for ever.
    double loop_virtual_s = 1.0;
    // Control-thread calls (create, configure, activate, name,
    // set_start_pose, destroy) [s], as the probe before a session allows.
    double control_s = 10.0;
    // deactivate() [s]: it may run on the loop thread, as the loop ends.
    double deactivate_s = 2.0;
    // How long a hung child may take to pass a halt to its plugin before
    // it is killed [s]: a USB or serial amplifier-disable transfer takes a
    // few ms (hapticlab/device_plugin.h tells plugin authors).
    double halt_grace_s = 0.010;
  };

  // Starts `host_executable` as the host, loads `path` there and creates
  // the device with `options`. Throws as PluginDevice does, with the same
  // messages (std::runtime_error: not a usable plugin, or the host could
  // not be started or crashed; std::invalid_argument: the plugin rejected
  // an option).
  IsolatedPluginDevice(const std::string& host_executable, const std::string& path,
                       const std::map<std::string, std::string>& options, const Bounds& bounds);
  IsolatedPluginDevice(const std::string& host_executable, const std::string& path,
                       const std::map<std::string, std::string>& options)
      : IsolatedPluginDevice(host_executable, path, options, Bounds{}) {}
  ~IsolatedPluginDevice() override;
  IsolatedPluginDevice(const IsolatedPluginDevice&) = delete;
  IsolatedPluginDevice& operator=(const IsolatedPluginDevice&) = delete;

  // --- Device
  DeviceStatus configure(const DeviceConfig& config) override;
  DeviceStatus activate(const Clock& clock) override;
  DeviceStatus read(DeviceReading& reading) noexcept override;
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() noexcept override;
  void halt() noexcept override;
  void halt_and_wait(double max_wait_s) noexcept override;
  bool halt_unconfirmed() const noexcept override;
  const char* name() const noexcept override { return name_.c_str(); }
  DeviceRatings ratings() const noexcept override { return ratings_; }
  HandAttachment* hand_attachment() noexcept override { return has_sim_ ? this : nullptr; }
  // "device_crashed: SIGSEGV in read", "device read hung for 20 ms"; "" if
  // the child is well.
  std::string fault_detail() const override;
  std::string status_detail() const override;

  // --- HandAttachment (only with the plugin's simulation extension)
  bool set_start_pose(int instrument, const DeviceJoints& position) noexcept override;
  void set_hand(int instrument, const HandCouplings& hand) noexcept override;
  DeviceJoints hand_force(int instrument) const noexcept override;
  DeviceJoints motor_force(int instrument) const noexcept override;

  // How the host process ended, in the words of the probe before a session
  // ("crashed (SIGSEGV) in configure", "ended the process (exit status 7)
  // in configure", "did not return from configure within 10 s"); "" while
  // it is well.
  std::string process_end() const;

  // Why the last configure() failed, for the operator ("" after a success).
  const std::string& configure_error() const noexcept { return configure_error_; }
  const std::string& path() const noexcept { return path_; }
  // The host process (for tests); 0 once it has been reaped.
  pid_t host_pid() const noexcept { return pid_; }

 private:
  enum class FaultKind : std::uint8_t { kNone, kSignal, kExit, kHung };
  struct Fault {
    FaultKind kind = FaultKind::kNone;
    PluginCallOp op = PluginCallOp::kNone;
    int code = 0;            // the signal or the exit status
    bool in_call = true;     // the child had begun the call
    double waited_ms = 0.0;  // kHung: how long the call was waited for
    double bound_s = 0.0;    // kHung: the call's bound
  };

  // Sends the call in channel_->call (its inputs filled in) and waits for
  // the answer at most `bound_s`. Returns kOk when answered; otherwise the
  // child is dead or killed, fault_ says why, and it returns
  // kDeviceCrashed or kDeviceHung. Real-time safe.
  DeviceStatus call(PluginCallOp op, double bound_s) const noexcept;
  // True, with fault_ filled in, if the child has ended (not reaped).
  bool child_ended(PluginCallOp op, std::uint32_t seq) const noexcept;
  void request_halt_and_wait(double max_wait_s) const noexcept;
  void wait_for_halt(std::uint32_t asked, double max_wait_s) const noexcept;
  // How long halt_unconfirmed() waits for a halt the host has not yet
  // confirmed before it says so [s]: a frozen host never does, a live one
  // on a loaded machine within milliseconds.
  static constexpr double kHaltConfirmWait_s = 0.2;
  void kill_hung(PluginCallOp op, double waited_ms, double bound_s) const noexcept;
  DeviceStatus fault_status() const noexcept;
  std::string process_end(const std::string& where) const;
  double loop_bound_s() const noexcept;
  // Control thread: waits for the child to end (killing it after
  // `patience_s`) and reaps it.
  void reap(double patience_s) noexcept;
  // The status of the call just answered (`unknown` for a code outside the
  // ABI), keeping the plugin's own code of that kind for status_detail().
  DeviceStatus answer(DeviceStatus unknown) const noexcept;
  // Cleans up and throws E("plugin PATH " + what).
  template <typename E = std::runtime_error>
  [[noreturn]] void fail_create(const std::string& what);

  std::string path_;
  Bounds bounds_;
  int memfd_ = -1;
  PluginChannel* channel_ = nullptr;
  pid_t pid_ = 0;
  // Calls are const where the Device interface is (hand_force, ...), but
  // each one moves the channel on.
  mutable std::uint32_t seq_ = 0;
  mutable bool dead_ = false;  // the child ended or was killed: nothing more is sent
  mutable Fault fault_;
  // The first failure since activate() when it was a code outside the ABI
  // (the host says which call, as PluginDevice::UnknownStatus).
  mutable std::atomic<std::int32_t> unknown_op_{0}, unknown_code_{0};
  // The channel's `halt` value of the last halt asked for (0: none yet).
  mutable std::atomic<std::uint32_t> halt_asked_{0};
  mutable bool sched_copied_ = false;
  const Clock* clock_ = nullptr;
  bool active_ = false;
  bool has_sim_ = false;
  std::string name_ = "plugin";
  DeviceRatings ratings_ = workstation_ratings();
  std::string configure_error_;
};

// The executable started as the host of isolated plugins: `hapticlab`
// registers itself (/proc/self/exe) at start-up, a test the `hapticlab` it
// was built with. Empty until then; open_device() refuses an isolated plugin
// without a host.
void set_plugin_host_executable(const std::string& path);
const std::string& plugin_host_executable() noexcept;

}  // namespace hapticlab
