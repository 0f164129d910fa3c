#include "core/models/moving_average.h"

namespace hapticlab {

double ShortWindowAverage::add(double value, double dt_s) noexcept {
  const double step_s = dt_s > 0.0 ? dt_s : 0.0;
  for (int i = kMaxSamples - 1; i > 0; --i) {
    values_[i] = values_[i - 1];
    ages_s_[i] = ages_s_[i - 1] + step_s;
  }
  values_[0] = value;
  ages_s_[0] = 0.0;
  if (count_ < kMaxSamples) ++count_;

  double sum = 0.0;
  int used = 0;
  // "20 ms window" is read as: the samples span at most 20 ms, so three
  // samples are used at 150 Hz and above (2 intervals <= 13.3 ms) — the
  // thesis' stated case — and fewer at lower rates.
  for (int i = 0; i < count_ && ages_s_[i] <= kMaxWindow_s + 1e-12; ++i) {
    sum += values_[i];
    ++used;
  }
  return sum / used;
}

}  // namespace hapticlab
