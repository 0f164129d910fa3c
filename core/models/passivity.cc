#include "core/models/passivity.h"

#include <algorithm>
#include <cmath>

namespace hapticlab {

void PassivityController::reset() noexcept {
  head_ = 0;
  count_ = 0;
  window_energy_ = 0.0;
  window_time_s_ = 0.0;
  dissipated_ = 0.0;
  last_damping_ = 0.0;
  before_ = {};
}

void PassivityController::push(double energy, double dt_s) noexcept {
  if (count_ == kCapacity) {  // full: the oldest leaves, whatever its age
    const std::size_t oldest = (head_ + kCapacity - count_) % kCapacity;
    window_energy_ -= energy_[oldest];
    window_time_s_ -= dt_[oldest];
    --count_;
  }
  energy_[head_] = energy;
  dt_[head_] = dt_s;
  head_ = (head_ + 1) % kCapacity;
  ++count_;
  window_energy_ += energy;
  window_time_s_ += dt_s;
}

double PassivityController::revise(const PassivityParams& p, double force) noexcept {
  if (!before_.valid) return force;
  const Before b = before_;
  head_ = b.head;
  count_ = b.count;
  window_energy_ = b.window_energy;
  window_time_s_ = b.window_time_s;
  dissipated_ = b.dissipated;
  energy_[head_] = b.overwritten_energy;
  dt_[head_] = b.overwritten_dt;
  const double out = step(p, force, b.velocity, b.dt_s);
  before_.valid = false;  // once per step
  return out;
}

double PassivityController::step(const PassivityParams& p, double force, double velocity, double dt_s) noexcept {
  last_damping_ = 0.0;
  before_.valid = false;
  if (!(dt_s > 0.0)) return force;
  before_ = {head_, count_, window_energy_, window_time_s_, dissipated_, energy_[head_], dt_[head_], velocity, dt_s,
             true};
  // Entries older than the window leave it, before this update is judged.
  while (count_ > 0 && window_time_s_ + dt_s > p.window_s) {
    const std::size_t oldest = (head_ + kCapacity - count_) % kCapacity;
    window_energy_ -= energy_[oldest];
    window_time_s_ -= dt_[oldest];
    --count_;
  }
  if (count_ == 0) window_energy_ = window_time_s_ = 0.0;  // no rounding residue carried on
  const double e = -force * velocity * dt_s;
  double out = force;
  const double observed = window_energy_ + e;
  // A femtojoule below zero is the sum's rounding, not a generated energy.
  constexpr double kRounding_J = 1e-15;
  if (observed < -kRounding_J && std::fabs(velocity) >= p.min_velocity) {
    const double alpha = std::min(-observed / (velocity * velocity * dt_s), p.max_damping);
    out = force - alpha * velocity;
    last_damping_ = alpha;
    dissipated_ += alpha * velocity * velocity * dt_s;
  }
  push(-out * velocity * dt_s, dt_s);
  return out;
}

}  // namespace hapticlab
