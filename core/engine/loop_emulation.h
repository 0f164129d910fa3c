#pragma once
// Emulation of a slower or later haptic loop for one 3-vector signal
// (beyond the thesis, which named update rate as a quality descriptor in
// Fig. 2-1 but did not degrade it).
//
//   delay: the output is the newest input that is at least `latency_s` old
//   hold:  the output changes only at `hold_rate_Hz` (zero-order hold)
//
// Fixed capacity, no allocation: at 2 kHz, 256 samples cover 128 ms, more
// than the 100 ms latency limit. At faster updates the latency is cut to
// what the buffer holds.

#include <array>

#include <Eigen/Core>

namespace hapticlab {

class SignalDelayHold {
 public:
  static constexpr int kCapacity = 256;

  void reset(const Eigen::Vector3d& value) noexcept;

  // Adds `value` observed dt_s after the previous one; returns the delayed,
  // held value.
  Eigen::Vector3d step(const Eigen::Vector3d& value, double dt_s, double latency_s,
                       double hold_rate_Hz) noexcept;

 private:
  struct Sample {
    double t_s;
    Eigen::Vector3d value;
  };
  std::array<Sample, kCapacity> ring_{};
  int newest_ = 0;
  int count_ = 0;
  int cursor_ = 0;  // index of the sample currently delivered by the delay
  double now_s_ = 0.0;
  double last_hold_s_ = 0.0;  // when the held value was last sampled
  Eigen::Vector3d held_ = Eigen::Vector3d::Zero();
};

}  // namespace hapticlab
