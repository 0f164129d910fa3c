#pragma once
// Velocity estimate for one DOF: backward difference of the measured position,
// then a first-order low-pass Butterworth filter (thesis eq. 2.1–2.2):
//
//   v_f(n) = b·(v_raw(n) + v_raw(n-1)) − a1·v_f(n-1)
//
// The thesis looked coefficients up in tables 10–200 Hz wide; we compute them
// from the dt measured at each update with the bilinear transform and
// frequency prewarping, K = tan(π·f_c·dt): b = K/(1+K), a1 = (K−1)/(K+1).
// That is MATLAB's butter(1, 2·f_c·dt) at every rate (to an ulp or two: K
// is the engine's sin/cos, poly_sin_cos.h).

namespace hapticlab {

// The thesis' cut-off: passes hand motion, rejects encoder/timing noise.
inline constexpr double kVelocityCutoff_Hz = 70.0;

struct ButterworthCoefficients {
  double b = 1.0;   // b(1) = b(2)
  double a1 = 0.0;  // a(2); a(1) = 1
};

// Valid for 0 < dt_s < 1/(2·cutoff_Hz); callers keep dt_s <= 1/150 s.
ButterworthCoefficients butterworth_lowpass_1st(double cutoff_Hz, double dt_s) noexcept;

// The coefficients for the last dt asked for. At a steady rate dt repeats
// exactly, and the two instruments of one loop update share their dt, while
// the sine and cosine cost as much as a few models. Gives bit for bit what
// butterworth_lowpass_1st gives. For 0 < dt_s < 1/(2·kVelocityCutoff_Hz).
class ButterworthCache {
 public:
  const ButterworthCoefficients& at(double dt_s) noexcept {
    if (dt_s != dt_s_) {
      coefficients_ = butterworth_lowpass_1st(kVelocityCutoff_Hz, dt_s);
      dt_s_ = dt_s;
    }
    return coefficients_;
  }

 private:
  double dt_s_ = 0.0;  // no coefficients yet
  ButterworthCoefficients coefficients_;
};

class VelocityFilter {
 public:
  // Forgets history: the next update starts from `position` at velocity
  // `velocity` (used on enable and after a stall).
  void reset(double position, double velocity = 0.0) noexcept;

  // Feeds a new position measured dt_s after the previous one and returns the
  // filtered velocity. dt_s == 0 holds the previous estimate and reference
  // position (the motion is counted at the next update with time).
  // Inline: it runs three times per update of every instrument.
  double update(double position, double dt_s, const ButterworthCoefficients& c) noexcept {
    if (!(dt_s > 0.0)) {
      // No time passed: a difference quotient is undefined. Keep the estimate
      // and the reference position, so the next update sees the whole motion
      // over the whole time.
      return filtered_;
    }
    const double raw = (position - last_position_) / dt_s;
    filtered_ = c.b * (raw + last_raw_) - c.a1 * filtered_;
    last_raw_ = raw;
    last_position_ = position;
    return filtered_;
  }

  double velocity() const noexcept { return filtered_; }

 private:
  double last_position_ = 0.0;
  double last_raw_ = 0.0;
  double filtered_ = 0.0;
};

}  // namespace hapticlab
