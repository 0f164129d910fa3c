#include "core/device/sim_device.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "core/common/csv_format.h"
#include "core/device/workstation_spec.h"
#include "core/common/clock.h"

namespace hapticlab {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// How far past its end stop an injected kOutOfRange puts the insertion [m].
constexpr double kInjectedOutOfRangeOffset_m = 0.020;

[[noreturn]] void fail_param(const std::string& field, double value, const std::string& rule) {
  throw std::invalid_argument("SimDevice(): " + field + " is " + format_number(value) +
                              ", but must be " + rule);
}

// Accepts value in [lo, hi]; NaN fails every comparison and is refused too.
void check_range(const std::string& field, double value, double lo, double hi,
                 const std::string& rule) {
  if (!(value >= lo && value <= hi)) fail_param(field, value, rule);
}

bool valid_instrument(int instrument) noexcept { return instrument == 0 || instrument == 1; }

bool coupling_is_valid(const HandCoupling& c) noexcept {
  const bool finite = std::isfinite(c.reference_position) && std::isfinite(c.reference_velocity) &&
                      std::isfinite(c.stiffness) && std::isfinite(c.damping) &&
                      std::isfinite(c.force) && std::isfinite(c.mass);
  return finite && c.stiffness >= 0.0 && c.damping >= 0.0 && c.mass >= 0.0;
}

}  // namespace

SimDevice::SimDevice(const SimDeviceParams& params) : params_(params) {
  constexpr double kMax = std::numeric_limits<double>::max();
  for (int j = 0; j < kNumDeviceJoints; ++j) {
    const SimJointParams& p = params.joints[j];
    const std::string prefix = "joints[" + std::to_string(j) + "].";
    if (!(p.mass > 0.0 && p.mass <= kMax)) fail_param(prefix + "mass", p.mass, "> 0 and finite");
    check_range(prefix + "static_friction", p.static_friction, 0.0, kMax, ">= 0 and finite");
    check_range(prefix + "dynamic_friction", p.dynamic_friction, 0.0, kMax, ">= 0 and finite");
    check_range(prefix + "stick_velocity", p.stick_velocity, 0.0, kMax, ">= 0 and finite");
  }
  if (!(params.thermal_time_constant_s > 0.0 && std::isfinite(params.thermal_time_constant_s))) {
    fail_param("thermal_time_constant_s", params.thermal_time_constant_s, "> 0 and finite");
  }
  // The lower bound keeps the sub-step count of a stall-length gap (10 s at
  // most) within an int.
  check_range("max_substep_s", params.max_substep_s, 1e-6, 1e-3, ">= 1e-6 and <= 1e-3");
  check_range("stall_gap_s", params.stall_gap_s, params.max_substep_s, 10.0,
              ">= max_substep_s and <= 10");
  check_range("out_of_range_tolerance_counts", params.out_of_range_tolerance_counts, 0.0, 1e9,
              ">= 0 and <= 1e9");

  // Start pose: insertion at mid-stroke, every angle at zero (the grip closed).
  for (auto& instrument : instruments_) {
    instrument[kJointInsertion].mass.reset(0.5 * kLswInsertionMax_m, 0.0);
  }
}

// --- Device lifecycle

DeviceStatus SimDevice::configure(const DeviceConfig& config) {
  if (active_) return DeviceStatus::kInvalidConfig;
  if (!(config.nominal_rate_Hz >= 150.0 && config.nominal_rate_Hz <= 2000.0)) {
    return DeviceStatus::kInvalidConfig;
  }
  configured_ = true;
  return DeviceStatus::kOk;
}

DeviceStatus SimDevice::activate(const Clock& clock) {
  if (!configured_) return DeviceStatus::kNotConfigured;
  if (not_calibrated_) return DeviceStatus::kNotCalibrated;
  const double now_s = clock.now_s();
  if (!std::isfinite(now_s)) return DeviceStatus::kInvalidConfig;
  clock_ = &clock;
  time_s_ = now_s;
  // Nothing is known about the time the device was off: start at rest, cold,
  // with every hand reference anchored now.
  for (auto& instrument : instruments_) {
    for (JointState& s : instrument) {
      s.mass.reset(s.mass.position(), 0.0);
      s.hand_set_time_s = now_s;
      s.command = 0.0;
      s.motor_force = 0.0;
      s.heat = 0.0;
      s.hand_force = 0.0;
    }
  }
  halted_.store(false, std::memory_order_release);
  active_ = true;
  return DeviceStatus::kOk;
}

DeviceStatus SimDevice::deactivate() noexcept {
  active_ = false;
  for (auto& instrument : instruments_) {
    for (JointState& s : instrument) {
      s.command = 0.0;
      s.motor_force = 0.0;
    }
  }
  return DeviceStatus::kOk;
}

// --- Real-time path

DeviceStatus SimDevice::read(DeviceReading& reading) noexcept {
  if (!active_) return DeviceStatus::kNotActive;

  // (clock) => (joint positions, velocities, hand and motor forces)
  advance_to(clock_->now_s());

  const bool faulted = time_s_ >= fault_time_s_;
  if (faulted && (fault_ == DeviceStatus::kReadFailed || fault_ == DeviceStatus::kTimeout)) return fault_;

  // (true positions) => (sensor counts × resolution): round to the nearest count.
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const double resolution = kWorkstationJoints[j].resolution;
      reading.position[i][j] = std::round(instruments_[i][j].mass.position() / resolution) * resolution;
    }
  }
  reading.device_time_s = time_s_;

  // Injected sensor faults corrupt the reading; the checks below report them
  // exactly as they would report a real device's.
  if (faulted && fault_ == DeviceStatus::kNonFiniteReading) {
    reading.position[0][kJointInsertion] = kNaN;
  } else if (faulted && fault_ == DeviceStatus::kOutOfRange) {
    reading.position[0][kJointInsertion] = kLswInsertionMax_m + kInjectedOutOfRangeOffset_m;
  }

  // (reading) => (status): non-finite first, since NaN is never out of range.
  for (const DeviceJoints& joints : reading.position) {
    for (double x : joints) {
      if (!std::isfinite(x)) return DeviceStatus::kNonFiniteReading;
    }
  }
  for (const DeviceJoints& joints : reading.position) {
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      const WorkstationJointSpec& spec = kWorkstationJoints[j];
      const double tolerance = params_.out_of_range_tolerance_counts * spec.resolution;
      if (joints[j] < spec.min_position - tolerance || joints[j] > spec.max_position + tolerance) {
        return DeviceStatus::kOutOfRange;
      }
    }
  }
  return DeviceStatus::kOk;
}

DeviceStatus SimDevice::write(const DeviceCommand& command) noexcept {
  if (!active_) return DeviceStatus::kNotActive;

  bool refused = time_s_ >= fault_time_s_ && fault_ == DeviceStatus::kWriteFailed;
  for (const DeviceJoints& joints : command.force) {
    for (double f : joints) refused = refused || !std::isfinite(f);
  }
  // A non-finite value never reaches a motor; neither does half a command.
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      instruments_[i][j].command = refused ? 0.0 : command.force[i][j];
    }
  }
  return refused ? DeviceStatus::kWriteFailed : DeviceStatus::kOk;
}

void SimDevice::set_hand(int instrument, const HandCouplings& hand) noexcept {
  if (!valid_instrument(instrument)) return;
  const double now_s = now_for_hand();
  for (int j = 0; j < kNumDeviceJoints; ++j) {
    JointState& s = instruments_[instrument][j];
    if (coupling_is_valid(hand[j])) {
      s.hand = hand[j];
    } else {
      s.hand = HandCoupling{};
      ++rejected_hand_updates_;
    }
    s.hand_set_time_s = now_s;
  }
}

double SimDevice::now_for_hand() const noexcept {
  if (active_ && clock_ != nullptr) {
    const double now_s = clock_->now_s();
    if (std::isfinite(now_s)) return now_s;
  }
  return time_s_;
}

// --- Physics

void SimDevice::advance_to(double t_s) noexcept {
  if (!std::isfinite(t_s) || !(t_s > time_s_)) return;
  double gap_s = t_s - time_s_;

  // A stall: re-anchor at rest and simulate only the last sub-step, so a
  // paused loop costs one sub-step and the hand reference, extrapolated over
  // the whole gap, cannot fling the joints.
  if (gap_s > params_.stall_gap_s) {
    for (auto& instrument : instruments_) {
      for (JointState& s : instrument) s.mass.reset(s.mass.position(), 0.0);
    }
    time_s_ = t_s - params_.max_substep_s;
    gap_s = t_s - time_s_;
  }

  // Equal sub-steps that land exactly on t_s. gap_s <= stall_gap_s <= 10 s
  // and max_substep_s >= 1 µs bound the count well within an int. The 1e-9
  // slack keeps a gap that is a whole number of sub-steps up to rounding
  // (1 ms from clock differences) at that number, so the discretization does
  // not depend on the read rate.
  const int n = std::max(
      1, static_cast<int>(std::ceil(gap_s / params_.max_substep_s * (1.0 - 1e-9))));
  const double h_s = gap_s / n;
  if (h_s != thermal_h_s_ || params_.thermal_time_constant_s != thermal_tau_s_) {
    thermal_h_s_ = h_s;
    thermal_tau_s_ = params_.thermal_time_constant_s;
    thermal_alpha_ = -std::expm1(-h_s / params_.thermal_time_constant_s);
  }
  const double thermal_alpha = thermal_alpha_;
  const double start_s = time_s_;
  for (int k = 1; k <= n; ++k) {
    const double end_s = (k == n) ? t_s : start_s + k * h_s;
    substep(end_s, thermal_alpha);
  }
}

void SimDevice::substep(double end_s, double thermal_alpha) noexcept {
  const double h_s = end_s - time_s_;
  for (auto& instrument : instruments_) {
    for (int j = 0; j < kNumDeviceJoints; ++j) {
      JointState& s = instrument[j];
      const SimJointParams& p = params_.joints[j];
      const WorkstationJointSpec& spec = kWorkstationJoints[j];

      // (command, heat) => (motor force): peak clip, continuous clip while hot.
      double f_motor = 0.0;
      if (is_actuated(static_cast<DeviceJoint>(j)) && !halted_.load(std::memory_order_relaxed)) {
        const double continuous = spec.continuous_force;
        const double limit = s.heat > continuous * continuous ? continuous : spec.peak_force;
        f_motor = std::clamp(s.command, -limit, limit);
      }
      s.motor_force = f_motor;
      s.heat += thermal_alpha * (f_motor * f_motor - s.heat);

      // (hand, motor, x) => (x', v'): spring and damper implicit in VirtualMass.
      const HandCoupling& hand = s.hand;
      const double x_ref = hand.reference_position + hand.reference_velocity * (end_s - s.hand_set_time_s);
      const MassForces forces{
          hand.stiffness * (x_ref - s.mass.position()) + hand.damping * hand.reference_velocity +
              hand.force + f_motor,
          hand.stiffness, hand.damping};
      const KarnoppFriction friction{p.static_friction, p.dynamic_friction, p.stick_velocity};
      s.mass.step(forces, p.mass + hand.mass, friction, h_s);

      // (x') => (x'): mechanical end stops absorb the outward motion.
      const double x = s.mass.position();
      const double v = s.mass.velocity();
      if (x < spec.min_position) {
        s.mass.reset(spec.min_position, std::max(v, 0.0));
      } else if (x > spec.max_position) {
        s.mass.reset(spec.max_position, std::min(v, 0.0));
      }

      // (x', v') => (hand force): what the participant feels.
      s.hand_force = hand.stiffness * (x_ref - s.mass.position()) +
                     hand.damping * (hand.reference_velocity - s.mass.velocity()) + hand.force;
    }
  }
  time_s_ = end_s;
}

// --- Simulation set-up and accessors

bool SimDevice::set_start_pose(int instrument, const DeviceJoints& position) noexcept {
  try {
    set_position(instrument, position);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

void SimDevice::set_position(int instrument, const DeviceJoints& position) {
  if (active_) throw std::logic_error("SimDevice::set_position(): call before activate()");
  if (!valid_instrument(instrument)) {
    throw std::invalid_argument("SimDevice::set_position(): instrument is " +
                                std::to_string(instrument) + ", but must be 0 or 1");
  }
  for (int j = 0; j < kNumDeviceJoints; ++j) {
    const WorkstationJointSpec& spec = kWorkstationJoints[j];
    if (!(position[j] >= spec.min_position && position[j] <= spec.max_position)) {
      throw std::invalid_argument("SimDevice::set_position(): joint " + std::to_string(j) +
                                  " is " + format_number(position[j]) + ", but must be >= " +
                                  format_number(spec.min_position) + " and <= " +
                                  format_number(spec.max_position));
    }
  }
  for (int j = 0; j < kNumDeviceJoints; ++j) {
    JointState& s = instruments_[instrument][j];
    s.mass.reset(position[j], 0.0);
    s.hand_force = 0.0;
  }
}

void SimDevice::inject_fault(DeviceStatus status, double at_time_s) {
  switch (status) {
    case DeviceStatus::kOk:
      fault_ = DeviceStatus::kOk;
      fault_time_s_ = std::numeric_limits<double>::infinity();
      not_calibrated_ = false;
      return;
    case DeviceStatus::kNotCalibrated:
      not_calibrated_ = true;
      return;
    case DeviceStatus::kTimeout:
    case DeviceStatus::kReadFailed:
    case DeviceStatus::kNonFiniteReading:
    case DeviceStatus::kOutOfRange:
    case DeviceStatus::kWriteFailed:
      break;
    default:
      throw std::invalid_argument(std::string("SimDevice::inject_fault(): status is ") +
                                  to_string(status) +
                                  ", but must be read_failed, device_timeout, non_finite_reading, "
                                  "out_of_range, write_failed, not_calibrated or ok");
  }
  if (std::isnan(at_time_s)) {
    throw std::invalid_argument("SimDevice::inject_fault(): at_time_s is NaN, but must be a time");
  }
  fault_ = status;
  fault_time_s_ = at_time_s;
}

DeviceJoints SimDevice::collect(int instrument, double JointState::*field) const noexcept {
  DeviceJoints out;
  if (!valid_instrument(instrument)) {
    out.fill(kNaN);
    return out;
  }
  for (int j = 0; j < kNumDeviceJoints; ++j) out[j] = instruments_[instrument][j].*field;
  return out;
}

DeviceJoints SimDevice::true_position(int instrument) const noexcept {
  DeviceJoints out;
  out.fill(kNaN);
  if (!valid_instrument(instrument)) return out;
  for (int j = 0; j < kNumDeviceJoints; ++j) out[j] = instruments_[instrument][j].mass.position();
  return out;
}

DeviceJoints SimDevice::velocity(int instrument) const noexcept {
  DeviceJoints out;
  out.fill(kNaN);
  if (!valid_instrument(instrument)) return out;
  for (int j = 0; j < kNumDeviceJoints; ++j) out[j] = instruments_[instrument][j].mass.velocity();
  return out;
}

DeviceJoints SimDevice::hand_force(int instrument) const noexcept {
  return collect(instrument, &JointState::hand_force);
}

DeviceJoints SimDevice::motor_force(int instrument) const noexcept {
  return collect(instrument, &JointState::motor_force);
}

DeviceJoints SimDevice::thermal_rms_force(int instrument) const noexcept {
  DeviceJoints out = collect(instrument, &JointState::heat);
  for (double& x : out) x = std::sqrt(x);
  return out;
}

}  // namespace hapticlab
