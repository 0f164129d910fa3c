#pragma once
// Update-rate cases every model is tested at: the thesis' range 150–2000 Hz,
// fixed and jittered (the thesis' VE wandered between 200 and 2000 Hz).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <ostream>
#include <string>

#include "core/engine/instrument.h"

namespace hapticlab::testing {

enum class Jitter {
  kNone,     // every dt is 1/rate
  kMild,     // uniform in [0.5, 1.5]·(1/rate)
  kWander,   // log-uniform over the whole 1/2000..1/150 s range, every update
};

struct RateCase {
  double rate_Hz;  // nominal; unused for kWander
  Jitter jitter = Jitter::kNone;
  bool jittered() const { return jitter != Jitter::kNone; }
};

inline std::string rate_name(const RateCase& c) {
  if (c.jitter == Jitter::kWander) return "wandering_150_to_2000Hz";
  return std::to_string(static_cast<int>(c.rate_Hz)) + "Hz" +
         (c.jitter == Jitter::kMild ? "_jittered" : "");
}

inline std::ostream& operator<<(std::ostream& os, const RateCase& c) { return os << rate_name(c); }

// Deterministic dt sequence for a rate case, always within 1/2000..1/150 s.
class DtSource {
 public:
  explicit DtSource(const RateCase& c, std::uint64_t seed = 12345) : case_(c), state_(seed) {}
  double next() {
    switch (case_.jitter) {
      case Jitter::kNone:
        return 1.0 / case_.rate_Hz;
      case Jitter::kMild:
        return std::clamp((0.5 + uniform()) / case_.rate_Hz, kMinDt_s, kMaxDt_s);
      case Jitter::kWander:
        return kMinDt_s * std::pow(kMaxDt_s / kMinDt_s, uniform());
    }
    return kMaxDt_s;
  }

 private:
  double uniform() {  // [0, 1), a fixed 64-bit LCG: identical on every platform
    state_ = state_ * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state_ >> 11) * 0x1.0p-53;
  }

  RateCase case_;
  std::uint64_t state_;
};

inline const RateCase kRateCases[] = {{150},
                                      {500},
                                      {2000},
                                      {500, Jitter::kMild},
                                      {0, Jitter::kWander}};

}  // namespace hapticlab::testing
