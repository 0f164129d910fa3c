#pragma once
// ReplayDevice, the "replay" backend: plays back the raw joint positions of a
// recorded trial, on the loop's clock, so a trial can be re-run through a
// different degradation setting or a changed VE with the very same motion.
//
// read() returns the last frame whose time since the first frame is <= the
// time since activate(), exactly as recorded (no interpolation: the bits a
// recording holds are the bits the loop sees), and kEndOfData once past the
// last frame (the reading then keeps the last frame). A recorded NaN or
// infinity is passed through and reported as kNonFiniteReading. Positions
// are not checked against the workstation's range: a recording may come from
// other hardware. write() has no motors to drive: it records the command
// (last_command()) and returns kOk.
//
// Threads: constructor, configure, activate, deactivate on the control
// thread; read/write on the loop thread (no allocation, locks or I/O).
// Not copyable or movable: the loop holds a pointer to its device.

#include <array>
#include <cstddef>
#include <filesystem>
#include <vector>

#include "core/device/device.h"

namespace hapticlab {

struct ReplayFrame {
  double t_s = 0.0;                         // recording time [s], finite
  std::array<DeviceJoints, 2> position{};  // per instrument [m, rad]
};

class ReplayDevice final : public Device {
 public:
  // `frames` non-empty, with finite, non-decreasing t_s; otherwise throws
  // std::invalid_argument naming the frame, its time and the rule.
  explicit ReplayDevice(std::vector<ReplayFrame> frames);
  ReplayDevice(const ReplayDevice&) = delete;
  ReplayDevice& operator=(const ReplayDevice&) = delete;

  // nominal_rate_Hz in [150, 2000], else kInvalidConfig (also while active).
  DeviceStatus configure(const DeviceConfig& config) override;
  // Starts playback from the first frame at clock.now_s(). `clock` must
  // outlive the activation.
  DeviceStatus activate(const Clock& clock) override;
  // device_time_s is the returned frame's recorded t_s.
  DeviceStatus read(DeviceReading& reading) noexcept override;
  DeviceStatus write(const DeviceCommand& command) noexcept override;
  DeviceStatus deactivate() noexcept override;
  const char* name() const noexcept override { return "replay"; }
  bool calls_may_block() const noexcept override { return false; }
  // No motors and nobody at a handle: the loop's range and velocity checks
  // have nothing to protect, and a recording may come from other hardware
  // (above), so the ranges and velocities are unbounded. The force ratings
  // stay the workstation's.
  DeviceRatings ratings() const noexcept override;

  // The command of the last write() while active (zero before any).
  const DeviceCommand& last_command() const noexcept { return last_command_; }
  const std::vector<ReplayFrame>& frames() const noexcept { return frames_; }
  // Recording length: last t_s − first t_s [s].
  double duration_s() const noexcept { return frames_.back().t_s - frames_.front().t_s; }

 private:
  std::vector<ReplayFrame> frames_;
  const Clock* clock_ = nullptr;
  bool configured_ = false;
  bool active_ = false;
  double start_s_ = 0.0;     // clock time of activate()
  std::size_t cursor_ = 0;   // frame last returned; only moves forward while active
  DeviceCommand last_command_{};
};

// Reads an engine trajectory CSV (core/device/trajectory_csv.h) — one row per
// instrument update, the two instruments interleaved — into frames: one per
// distinct t_s, holding each instrument's latest insertion, pitch and yaw
// (twist and grip 0). Before an instrument's first row it holds its first
// recorded position; an instrument with no row at all stays at zero. Rows
// are ordered by t_s (stable, so of two rows of one instrument at one time
// the later in the file wins). Throws TrajectoryCsvError for a malformed or
// empty file.
std::vector<ReplayFrame> load_replay_frames_from_trajectory_csv(const std::filesystem::path& path);

}  // namespace hapticlab
