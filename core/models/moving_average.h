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
  // Inline: it runs on every axis with inertia or backlash, every update.
  double add(double value, double dt_s) noexcept {
    const double step_s = dt_s > 0.0 ? dt_s : 0.0;
    // Newest first: shift the older samples back and age them by this step.
    values_[2] = values_[1];
    ages_s_[2] = ages_s_[1] + step_s;
    values_[1] = values_[0];
    ages_s_[1] = ages_s_[0] + step_s;
    values_[0] = value;
    ages_s_[0] = 0.0;
    if (count_ < kMaxSamples) ++count_;

    // "20 ms window" is read as: the samples span at most 20 ms, so three
    // samples are used at 150 Hz and above (2 intervals <= 13.3 ms) — the
    // thesis' stated case — and fewer at lower rates. The newest always
    // counts; the sum runs newest first.
    constexpr double kLimit_s = kMaxWindow_s + 1e-12;
    double sum = 0.0 + values_[0];
    if (count_ < 2 || !(ages_s_[1] <= kLimit_s)) return sum / 1.0;
    sum += values_[1];
    if (count_ < 3 || !(ages_s_[2] <= kLimit_s)) return sum / 2.0;
    sum += values_[2];
    return sum / 3.0;
  }
  static_assert(kMaxSamples == 3, "add() is written out for three samples");

 private:
  // Newest first. ages_s_[i] is the time from sample i to the newest sample.
  std::array<double, kMaxSamples> values_{};
  std::array<double, kMaxSamples> ages_s_{};
  int count_ = 0;
};

}  // namespace hapticlab
