#include "core/loop/rate_schedule.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace hapticlab {
namespace {

void check_rate(const char* caller, const char* name, double value_Hz) {
  if (value_Hz >= RateSchedule::kMinRate_Hz && value_Hz <= RateSchedule::kMaxRate_Hz) return;
  std::ostringstream message;
  message.precision(17);
  message << caller << ": " << name << " is " << value_Hz << " Hz, but must be >= "
          << RateSchedule::kMinRate_Hz << " and <= " << RateSchedule::kMaxRate_Hz << " Hz";
  throw std::invalid_argument(message.str());
}

}  // namespace

RateSchedule RateSchedule::fixed(double rate_Hz) {
  check_rate("RateSchedule::fixed()", "rate_Hz", rate_Hz);
  return RateSchedule(false, rate_Hz, rate_Hz, 0);
}

RateSchedule RateSchedule::thesis_wander(std::uint64_t seed, double min_Hz, double max_Hz) {
  check_rate("RateSchedule::thesis_wander()", "min_Hz", min_Hz);
  check_rate("RateSchedule::thesis_wander()", "max_Hz", max_Hz);
  if (!(min_Hz <= max_Hz)) {
    std::ostringstream message;
    message.precision(17);
    message << "RateSchedule::thesis_wander(): min_Hz (" << min_Hz << " Hz) must be <= max_Hz ("
            << max_Hz << " Hz)";
    throw std::invalid_argument(message.str());
  }
  return RateSchedule(true, min_Hz, max_Hz, seed);
}

RateSchedule::RateSchedule(bool wander, double min_Hz, double max_Hz, std::uint64_t seed) noexcept
    : wander_(wander),
      min_Hz_(min_Hz),
      max_Hz_(max_Hz),
      min_log_(std::log(min_Hz)),
      max_log_(std::log(max_Hz)),
      centre_log_(0.5 * (min_log_ + max_log_)),
      sigma_log_(0.25 * (max_log_ - min_log_)),
      log_rate_(centre_log_),
      rng_(seed) {
  if (wander_) log_rate_ = reflect_into_range(centre_log_ + sigma_log_ * rng_.normal());
}

double RateSchedule::reflect_into_range(double y) const noexcept {
  // A step is a fraction of the range, so one or two reflections suffice; the
  // clamp covers rounding and a zero-width range.
  for (int k = 0; k < 4; ++k) {
    if (y > max_log_) {
      y = 2.0 * max_log_ - y;
    } else if (y < min_log_) {
      y = 2.0 * min_log_ - y;
    } else {
      break;
    }
  }
  return std::clamp(y, min_log_, max_log_);
}

double RateSchedule::next_period_s() noexcept {
  if (!wander_) return 1.0 / min_Hz_;

  // (y, jitter) => (period): this update's period at the current rate.
  const double jitter = std::exp(kWanderJitterLogSd * rng_.normal());
  const double period_s = std::clamp(std::exp(-log_rate_) * jitter, 1.0 / max_Hz_, 1.0 / min_Hz_);

  // (y, period) => (y): the walk moves on by exactly this period.
  const double decay = std::exp(-period_s / kWanderTimeConstant_s);
  const double spread = sigma_log_ * std::sqrt(1.0 - decay * decay);
  log_rate_ = reflect_into_range(centre_log_ + (log_rate_ - centre_log_) * decay +
                                 spread * rng_.normal());
  return period_s;
}

double RateSchedule::nominal_period_s() const noexcept {
  return wander_ ? std::exp(-centre_log_) : 1.0 / min_Hz_;
}

}  // namespace hapticlab
