#pragma once
// Emulation of a slower or later haptic loop for one 3-vector signal
// (beyond the thesis, which named update rate as a quality descriptor in
// Fig. 2-1 but did not degrade it).
//
//   delay: the output is the newest input that is at least `latency_s` old
//   hold:  the output changes only at `hold_rate_Hz` (zero-order hold)
//
// Fixed capacity, no allocation: 256 samples kept at least 0.4 ms apart
// cover 102 ms, more than the 100 ms latency limit, at any update rate. A
// sample less than 0.4 ms after the last kept one is not kept: at a steady
// rate up to 2.5 kHz that is none (every update's sample is kept, as
// before this rule), in a jittered loop an update that came early or
// repeated a time, and above 2.5 kHz enough that the delay is resolved to
// 0.4 ms plus one update (the latency, up to that much more) rather than
// cut to what 256 samples of a fast loop span (26 ms at 10 kHz before).

#include <array>

#include <Eigen/Core>

namespace hapticlab {

class SignalDelayHold {
 public:
  static constexpr int kCapacity = 256;
  // The closest two kept samples may be [s]; the rounding slack keeps a
  // steady 2.5 kHz's accumulated time from dropping every other sample.
  static constexpr double kMinSpacing_s = 0.4e-3;
  static constexpr double kMaxLatency_s = 0.1;  // settings' loop.*_latency_s limit
  static_assert((kCapacity - 1) * (kMinSpacing_s - 1e-9) >= kMaxLatency_s,
                "the ring must span the longest latency at the closest spacing");

  void reset(const Eigen::Vector3d& value) noexcept;

  // Adds `value` observed dt_s after the previous one; returns the delayed,
  // held value. Inline for the common case (no latency, no hold), which
  // every update of both instruments goes through twice.
  Eigen::Vector3d step(const Eigen::Vector3d& value, double dt_s, double latency_s,
                       double hold_rate_Hz) noexcept {
    now_s_ += dt_s > 0.0 ? dt_s : 0.0;
    if (now_s_ - ring_[newest_].t_s >= kMinSpacing_s - 1e-9) {
      newest_ = next(newest_);
      ring_[newest_] = {now_s_, value};
      if (count_ < kCapacity) {
        ++count_;
      } else if (cursor_ == newest_) {
        // Overwritten: the oldest stored sample is the best we have.
        cursor_ = next(newest_);
      }
    }
    if (latency_s <= 0.0 && hold_rate_Hz <= 0.0) {
      cursor_ = newest_;
      return held_ = value;
    }
    return delay_and_hold(value, latency_s, hold_rate_Hz);
  }

 private:
  static_assert((kCapacity & (kCapacity - 1)) == 0, "a power of two: the ring's index wraps by a mask");
  static int next(int index) noexcept { return (index + 1) & (kCapacity - 1); }
  Eigen::Vector3d delay_and_hold(const Eigen::Vector3d& value, double latency_s, double hold_rate_Hz) noexcept;

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
