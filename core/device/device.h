#pragma once
// One interface for every haptic device: the simulated workstation, replay
// of a recorded trial, and (through the C API) external hardware.
//
// Lifecycle: configure -> activate -> { read, write }* -> deactivate.
// Every call returns a DeviceStatus; nothing throws. read() and write() are
// called by the haptic loop's real-time thread: they must not allocate, lock
// or block beyond the device's own bus transfer.
//
// Joint order and units (thesis Table 2.1, Laparoscopic Surgical Workstation):
//   insertion [m], pitch [rad], yaw [rad], handle twist [rad], grip [rad].
// Forces/torques follow the same order: insertion [N], pitch/yaw/twist/grip
// [N·m]. Twist is not actuated on the LSW; a command on it is ignored.

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace hapticlab {

enum DeviceJoint : int { kJointInsertion = 0, kJointPitch, kJointYaw, kJointTwist, kJointGrip };
inline constexpr int kNumDeviceJoints = 5;

using DeviceJoints = std::array<double, kNumDeviceJoints>;

enum class DeviceStatus : std::int32_t {
  kOk = 0,
  kNotConfigured,      // activate() before configure()
  kNotActive,          // read()/write() outside activate()..deactivate()
  kInvalidConfig,      // configure() got a value outside its documented range
  kReadFailed,         // the transfer failed (bus error, device unplugged)
  kNonFiniteReading,   // the device returned NaN or infinity
  kOutOfRange,         // a reading lies outside the joint's mechanical range
  kWriteFailed,        // the force command could not be sent
  kEndOfData,          // replay: the recording is exhausted
  kNotCalibrated,      // activate(): the device is not calibrated or homed; it must not be driven
  kTimeout,            // read(): no answer within the device's timeout (network bridge)
  // An isolated plugin (IsolatedPluginDevice): the process serving it died
  // during the call (a crash, an exit), or did not answer within the call's
  // bound and was killed. fault_detail() gives the reason in full
  // ("device_crashed: SIGSEGV in read", "device read hung for 20 ms").
  kDeviceCrashed,
  kDeviceHung,
};
inline constexpr int kNumDeviceStatuses = 13;

// A short, stable name for logs and error messages ("read_failed", ...).
const char* to_string(DeviceStatus status) noexcept;

struct DeviceReading {
  // One row per instrument: 0 = left, 1 = right.
  std::array<DeviceJoints, 2> position{};
  // The device's own timestamp of the reading [s], if it has one (sim and
  // replay do); NaN otherwise. The loop measures dt with its own clock.
  double device_time_s = 0.0;
};

struct DeviceCommand {
  std::array<DeviceJoints, 2> force{};  // N and N·m, see the joint order above
};

struct DeviceConfig {
  // Loop rate the device should expect [Hz], 150..2000 (informative for sim,
  // used by drivers that need a bus schedule).
  double nominal_rate_Hz = 1000.0;
  // Seed for anything random in a simulated device (sensor noise); devices
  // that are not simulated ignore it.
  std::uint64_t seed = 0;
};

// What a device can do and take, per instrument and DeviceJoint. [X] = m
// for insertion, rad otherwise; [F] = N or N·m. The loop's safety guard
// never commands more than peak_force (and lowers it further if the
// protocol asks), treats a reading outside [min_position, max_position]
// (widened by 5 % of the span) as a fault, and zeroes the force and ends
// the trial when a joint moves faster than max_velocity (docs/safety.md). Defaults: the Laparoscopic Surgical Workstation (thesis
// Table 2.1; core/device/workstation_spec.h).
struct DeviceJointRating {
  double min_position = 0.0;     // [X]
  double max_position = 0.0;     // [X] > min_position
  double continuous_force = 0.0; // [F] >= 0, sustainable output
  double peak_force = 0.0;       // [F] >= continuous_force, short-term output
  double max_velocity = 0.0;     // [X/s] > 0, faster is a fault (a runaway or a bad reading)
};
struct DeviceRatings {
  std::array<std::array<DeviceJointRating, kNumDeviceJoints>, 2> joint{};
};
// The Laparoscopic Surgical Workstation's ratings, for both instruments.
DeviceRatings workstation_ratings() noexcept;

class Clock;
class HandAttachment;

class Device {
 public:
  virtual ~Device() = default;

  // Control thread. May be called again while inactive to reconfigure.
  virtual DeviceStatus configure(const DeviceConfig& config) = 0;
  // Control thread. Powers the amplifiers / starts playback. `clock` is the
  // loop's clock; simulated devices advance their physics to clock.now_s().
  virtual DeviceStatus activate(const Clock& clock) = 0;
  // Real-time thread.
  virtual DeviceStatus read(DeviceReading& reading) noexcept = 0;
  // Real-time thread. Forces are clipped by the device to its peak limits.
  virtual DeviceStatus write(const DeviceCommand& command) noexcept = 0;
  // Control thread. Zero forces, amplifiers off. Always safe to call.
  virtual DeviceStatus deactivate() noexcept = 0;
  // Any thread, at any time, concurrently with read()/write(): stop the
  // force output now (amplifier enable off, a zero-force latch), without
  // waiting for the loop, which may be the thing that hangs. The loop's
  // watchdog calls it; deactivate() follows once the loop ends. Forces stay
  // off until the next activate(). Default: nothing beyond what write()
  // does, for devices without a separate way to cut the output.
  virtual void halt() noexcept {}
  // halt(), and for a device whose halt runs elsewhere (an isolated
  // plugin's host process) a wait of up to max_wait_s for it to be done.
  // For a process about to die (its crash handler): the host would be
  // killed with it, maybe before the halt reached the plugin.
  // Async-signal-safe where halt() is. Default: halt().
  virtual void halt_and_wait(double max_wait_s) noexcept {
    (void)max_wait_s;
    halt();
  }
  // Any thread, after halt(): true when the last halt was handed to
  // something that has not said it is done (an isolated plugin's host that
  // is frozen or was killed first): the output may still be on, and what
  // the operator is told must not claim zero force. May wait a moment for
  // the confirmation (the isolated device: up to 0.2 s). Default: false
  // (halt() itself cut the output before it returned).
  virtual bool halt_unconfirmed() const noexcept { return false; }

  // Real-time thread, once per loop run, before its first read(): the
  // clock's time of the loop's first update. The loop's t_s (the stored
  // samples' time) is clock.now_s() - t0_s; a device that sends the time
  // elsewhere (the UDP bridge's POLL) sends it in this base, so the far
  // side's log lines up with the study file. Default: nothing.
  virtual void set_loop_origin(double t0_s) noexcept { (void)t0_s; }
  // Any thread. The longest a read() waits for the device before it gives
  // up with kTimeout [s]; 0 (default) for a device that does not wait. The
  // loop's watchdog allows this on top of its own limit, so a device that
  // stops answering ends the trial with the device's reason.
  virtual double read_timeout_s() const noexcept { return 0.0; }

  virtual const char* name() const noexcept = 0;

  // Any thread. What the device can do (see DeviceRatings); fixed once
  // configure() succeeded.
  virtual DeviceRatings ratings() const noexcept { return workstation_ratings(); }

  // A simulated device a simulated participant can hold; null for hardware,
  // which a person holds.
  virtual HandAttachment* hand_attachment() noexcept { return nullptr; }

  // Control thread, after the loop: the device's own counts for the
  // trial's record (the UDP bridge's lost and malformed packets, ...), as
  // name/value pairs in a stable order. Default: none.
  virtual std::vector<std::pair<std::string, std::uint64_t>> counters() const { return {}; }
  // Control thread, after read() or write() failed: what went wrong, for
  // the operator ("no answer from udp:127.0.0.1:5000 within 10 ms"); empty
  // when the status says it all.
  virtual std::string fault_detail() const { return {}; }
  // Control thread, after the loop: what the device knows, beyond the
  // status itself, of the first failure the device reported since
  // activate() (a plugin's code outside the ABI: "the plugin's read
  // returned 42, which is no hl_device_status (taken as read_failed)");
  // empty when the status says it all. Unlike fault_detail(), never about
  // calls after that failure (the loop's zero write and deactivate).
  virtual std::string status_detail() const { return {}; }
  // Whether read() and write() can wait on something outside this process
  // (a bus, a socket, a plugin's driver), so that a loop stalled inside
  // them points at the device. false for devices that only compute (the
  // built-in simulation, replay): a stall there is the host's.
  virtual bool calls_may_block() const noexcept { return true; }
};

}  // namespace hapticlab
