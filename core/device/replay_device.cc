#include "core/device/replay_device.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/common/csv_format.h"
#include "core/device/trajectory_csv.h"
#include "core/common/clock.h"

namespace hapticlab {

ReplayDevice::ReplayDevice(std::vector<ReplayFrame> frames) : frames_(std::move(frames)) {
  if (frames_.empty()) throw std::invalid_argument("replay: frames is empty, but must hold at least one frame");
  for (std::size_t k = 0; k < frames_.size(); ++k) {
    const double t_s = frames_[k].t_s;
    if (!std::isfinite(t_s)) {
      throw std::invalid_argument("replay: frame " + std::to_string(k) + " has t_s = " +
                                  format_number(t_s) + ", but t_s must be finite");
    }
    if (k > 0 && t_s < frames_[k - 1].t_s) {
      throw std::invalid_argument("replay: frame " + std::to_string(k) + " has t_s = " +
                                  format_number(t_s) + " s, before frame " + std::to_string(k - 1) +
                                  " (" + format_number(frames_[k - 1].t_s) +
                                  " s); frames must be sorted by non-decreasing t_s");
    }
  }
}

DeviceStatus ReplayDevice::configure(const DeviceConfig& config) {
  if (active_) return DeviceStatus::kInvalidConfig;
  if (!(config.nominal_rate_Hz >= 150.0 && config.nominal_rate_Hz <= 2000.0)) {
    return DeviceStatus::kInvalidConfig;
  }
  configured_ = true;
  return DeviceStatus::kOk;
}

DeviceStatus ReplayDevice::activate(const Clock& clock) {
  if (!configured_) return DeviceStatus::kNotConfigured;
  clock_ = &clock;
  start_s_ = clock.now_s();
  cursor_ = 0;
  last_command_ = DeviceCommand{};
  active_ = true;
  return DeviceStatus::kOk;
}

DeviceStatus ReplayDevice::deactivate() noexcept {
  active_ = false;
  return DeviceStatus::kOk;
}

DeviceRatings ReplayDevice::ratings() const noexcept {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  DeviceRatings r = workstation_ratings();
  for (auto& instrument : r.joint)
    for (DeviceJointRating& joint : instrument) {
      joint.min_position = -kInf;
      joint.max_position = kInf;
      joint.max_velocity = kInf;
    }
  return r;
}

DeviceStatus ReplayDevice::read(DeviceReading& reading) noexcept {
  if (!active_) return DeviceStatus::kNotActive;
  // A clock that advances by adding periods lands a few ulps short of a
  // frame's stamp (1.0079999999999998 for 1.008); 1 ns of grace, far below
  // any update period (>= 0.5 ms), keeps such a frame due on time.
  constexpr double kStampTolerance_s = 1e-9;
  const double elapsed_s = clock_->now_s() - start_s_;
  const double first_s = frames_.front().t_s;

  // The clock never runs backwards, so the cursor only moves forward: O(1)
  // per read on average, whatever the recording's length.
  while (cursor_ + 1 < frames_.size() && frames_[cursor_ + 1].t_s - first_s <= elapsed_s + kStampTolerance_s) ++cursor_;

  const ReplayFrame& frame = frames_[cursor_];
  reading.position = frame.position;
  reading.device_time_s = frame.t_s;

  if (elapsed_s > frames_.back().t_s - first_s + kStampTolerance_s) return DeviceStatus::kEndOfData;
  for (const DeviceJoints& joints : frame.position) {
    for (double x : joints) {
      if (!std::isfinite(x)) return DeviceStatus::kNonFiniteReading;
    }
  }
  return DeviceStatus::kOk;
}

DeviceStatus ReplayDevice::write(const DeviceCommand& command) noexcept {
  if (!active_) return DeviceStatus::kNotActive;
  last_command_ = command;
  return DeviceStatus::kOk;
}

std::vector<ReplayFrame> load_replay_frames_from_trajectory_csv(const std::filesystem::path& path) {
  struct Sample {
    double t_s;
    int instrument;
    DeviceJoints position;
  };
  std::vector<Sample> samples;
  TrajectoryCsvReader reader(path);
  TrajectoryRow row;
  // Per instrument: its last row's time and line (rows of one instrument do
  // not go back in time: the reader checks it).
  std::array<double, 2> last_t_s{};
  std::array<std::size_t, 2> last_line{};
  while (reader.next(row)) {
    const std::size_t k = static_cast<std::size_t>(row.instrument);
    // A device shows one position at a time: two rows of one instrument at
    // one time would leave the first unseen (the engine's replay reads them
    // as dt = 0; a replayed device cannot).
    if (last_line[k] != 0 && row.t_s == last_t_s[k]) {
      throw TrajectoryCsvError(path.string() + ":" + std::to_string(reader.line_number()) + ": instrument " +
                               std::to_string(row.instrument) + " has a second row at t_s " + format_number(row.t_s) +
                               " (line " + std::to_string(last_line[k]) +
                               " is the first); a replayed device shows one position at a time");
    }
    last_t_s[k] = row.t_s;
    last_line[k] = reader.line_number();
    DeviceJoints q{};
    q[kJointInsertion] = row.position(0);
    q[kJointPitch] = row.position(1);
    q[kJointYaw] = row.position(2);
    samples.push_back({row.t_s, row.instrument, q});
  }
  if (samples.empty()) {
    throw TrajectoryCsvError(path.string() + ": no rows; a replay needs at least one");
  }
  // Both instruments: one without rows would be replayed at zero (the tool
  // at its pivot), which no recording said.
  for (int k = 0; k < 2; ++k) {
    if (last_line[static_cast<std::size_t>(k)] == 0)
      throw TrajectoryCsvError(path.string() + ": instrument " + std::to_string(k) +
                               " has no rows; a replay moves both instruments (give it at least one row, "
                               "a constant position if it did not move)");
  }
  // Rows of the two instruments may interleave out of global time order.
  std::stable_sort(samples.begin(), samples.end(),
                   [](const Sample& a, const Sample& b) { return a.t_s < b.t_s; });

  std::vector<ReplayFrame> frames;
  std::array<DeviceJoints, 2> latest{};
  std::array<bool, 2> seen{};
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const Sample& s = samples[k];
    latest[s.instrument] = s.position;
    if (!seen[s.instrument]) {
      // Before its first row the instrument holds its first recorded position.
      seen[s.instrument] = true;
      for (ReplayFrame& earlier : frames) earlier.position[s.instrument] = s.position;
    }
    // One frame per distinct time, after all rows at that time.
    if (k + 1 == samples.size() || samples[k + 1].t_s != s.t_s) frames.push_back({s.t_s, latest});
  }
  return frames;
}

}  // namespace hapticlab
