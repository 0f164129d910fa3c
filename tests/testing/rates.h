#pragma once
// Update-rate cases every model is tested at: the thesis' range 150–2000 Hz,
// fixed and jittered (the thesis' VE wandered between 200 and 2000 Hz).

#include <cstdint>
#include <ostream>
#include <string>

#include "core/engine/instrument.h"

namespace hapticlab::testing {

struct RateCase {
  double rate_Hz;
  bool jitter;
};

inline std::ostream& operator<<(std::ostream& os, const RateCase& c) {
  return os << c.rate_Hz << "Hz" << (c.jitter ? "_jittered" : "");
}

inline std::string rate_name(const RateCase& c) {
  return std::to_string(static_cast<int>(c.rate_Hz)) + "Hz" + (c.jitter ? "_jittered" : "");
}

// Deterministic dt sequence. Jittered: uniform in [0.5, 1.5]·(1/rate),
// kept inside the specified 1/2000..1/150 s range.
class DtSource {
 public:
  explicit DtSource(const RateCase& c, std::uint64_t seed = 12345) : case_(c), state_(seed) {}
  double next() {
    const double nominal_s = 1.0 / case_.rate_Hz;
    if (!case_.jitter) return nominal_s;
    state_ = state_ * 6364136223846793005ULL + 1442695040888963407ULL;
    const double u = static_cast<double>(state_ >> 11) * 0x1.0p-53;
    double dt = nominal_s * (0.5 + u);
    if (dt < kMinDt_s) dt = kMinDt_s;
    if (dt > kMaxDt_s) dt = kMaxDt_s;
    return dt;
  }

 private:
  RateCase case_;
  std::uint64_t state_;
};

inline const RateCase kRateCases[] = {{150, false}, {500, false}, {2000, false}, {500, true}};

}  // namespace hapticlab::testing
