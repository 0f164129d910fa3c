#pragma once
// Second low-pass stage of the inertia model (thesis 2.2.1.2): the coupling
// force is averaged over the last three updates or the last 20 ms, whichever
// is shorter. The current update always counts, so at rates below 100 Hz the
// window degrades gracefully to the current value alone.

#include <array>

namespace hapticlab {

class ShortWindowAverage {
 public:
  static constexpr int kMaxSamples = 3;
  static constexpr double kMaxWindow_s = 0.020;

  void reset() noexcept { count_ = 0; }

  // Adds a sample taken dt_s after the previous one and returns the mean of
  // the samples that lie within the window.
  double add(double value, double dt_s) noexcept;

 private:
  // Newest first. ages_s_[i] is the time from sample i to the newest sample.
  std::array<double, kMaxSamples> values_{};
  std::array<double, kMaxSamples> ages_s_{};
  int count_ = 0;
};

}  // namespace hapticlab
