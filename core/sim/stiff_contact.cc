#include "core/sim/stiff_contact.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/common/csv_format.h"
#include "core/device/sim_device.h"
#include "core/engine/instrument.h"
#include "core/engine/joint_transform.h"
#include "core/engine/status.h"
#include "core/common/clock.h"

namespace hapticlab {
namespace {

void check(const char* field, double value, double min, double max) {
  if (value >= min && value <= max) return;
  throw std::invalid_argument("stiff contact: " + std::string(field) + " is " + format_number(value) +
                              ", but must be >= " + format_number(min) + " and <= " + format_number(max));
}

void validate(const StiffContactConfig& c) {
  check("rate_Hz", c.rate_Hz, 150.0, 2000.0);
  check("stiffness_N_per_m", c.stiffness_N_per_m, 1e-3, 1e6);
  check("damping_N_s_per_m", c.damping_N_s_per_m, 0.0, 1e4);
  check("press_N", c.press_N, 0.0, 50.0);
  check("hand_stiffness_N_per_m", c.hand_stiffness_N_per_m, 1.0, 1e5);
  check("hand_damping_ratio", c.hand_damping_ratio, 0.0, 10.0);
  check("hand_mass_kg", c.hand_mass_kg, 0.0, 10.0);
  check("duration_s", c.duration_s, 1.5, 600.0);
  check("start_insertion_m", c.start_insertion_m, 0.02, 0.15);
}

}  // namespace

StiffContactResult run_stiff_contact(const StiffContactConfig& c) {
  validate(c);
  StiffContactResult result;
  VirtualClock clock;
  SimDevice device;
  const DeviceJoints start{c.start_insertion_m, 0.0, 0.0, 0.0, 0.0};
  if (device.configure({.nominal_rate_Hz = c.rate_Hz}) != DeviceStatus::kOk || !device.set_start_pose(0, start) ||
      device.activate(clock) != DeviceStatus::kOk) {
    throw std::invalid_argument("stiff contact: the simulated device refused the start pose");
  }

  // The hand: pushes along the tool, holds pitch and yaw (tip impedance
  // through the lever L = insertion).
  const double lever_m = c.start_insertion_m;
  const double k = c.hand_stiffness_N_per_m;
  const double b = c.hand_damping_ratio * 2.0 * std::sqrt(k * c.hand_mass_kg);
  HandCouplings hand{};
  hand[kJointInsertion] = {c.start_insertion_m + c.press_N / k, 0.0, k, b, 0.0, c.hand_mass_kg};
  for (int j : {kJointPitch, kJointYaw})
    hand[j] = {0.0, 0.0, k * lever_m * lever_m, b * lever_m * lever_m, 0.0, c.hand_mass_kg * lever_m * lever_m};
  device.set_hand(0, hand);

  const JointVector q0(start[kJointInsertion], start[kJointPitch], start[kJointYaw]);
  const Eigen::Vector3d anchor_m = tip_position(q0);
  const Eigen::Vector3d normal = anchor_m.normalized();  // along the tool, into the body
  Instrument instrument(c.settings, q0);

  const double dt_s = 1.0 / c.rate_Hz;
  const auto updates = static_cast<long>(std::llround(c.duration_s * c.rate_Hz));
  const double judged_from_s = c.duration_s - 1.0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  Eigen::Vector3d ve_force_N = Eigen::Vector3d::Zero();
  JointVector held_force = JointVector::Zero();
  JointVector q_prev = q0;
  DeviceReading reading;
  DeviceCommand command;
  for (long n = 1; n <= updates; ++n) {
    const double t_s = n * dt_s;
    clock.sleep_until(t_s);
    if (device.read(reading) != DeviceStatus::kOk) {
      result.faulted = true;
      break;
    }
    const DeviceJoints& d = reading.position[0];
    const JointVector q(d[kJointInsertion], d[kJointPitch], d[kJointYaw]);
    result.device_net_J += held_force.dot(q - q_prev);
    q_prev = q;
    InstrumentOutput out = instrument.step({dt_s, q, ve_force_N});
    // The VE's answer to the new degraded tip.
    const Eigen::Vector3d offset_m = out.degraded_tip_m - anchor_m;
    if (c.kind == StiffContactKind::kWall) {
      const double depth_m = offset_m.dot(normal);
      ve_force_N = depth_m > 0.0 ? Eigen::Vector3d(-c.stiffness_N_per_m * depth_m * normal) : Eigen::Vector3d::Zero();
    } else {
      ve_force_N = -c.stiffness_N_per_m * offset_m;
    }
    instrument.refresh_forces(ve_force_N, out);
    if (out.status & kFaultMask) {
      result.faulted = true;
      break;
    }
    result.peak_ve_force_N = std::max(result.peak_ve_force_N, ve_force_N.norm());
    held_force = out.joint_force;
    command.force[0] = {out.joint_force[0], out.joint_force[1], out.joint_force[2], 0.0, 0.0};
    if (device.write(command) != DeviceStatus::kOk) {
      result.faulted = true;
      break;
    }
    result.ran_s = t_s;
    if (t_s >= judged_from_s) {
      const Eigen::Vector3d tip = tip_position(q);
      lo = lo.cwiseMin(tip);
      hi = hi.cwiseMax(tip);
    }
  }
  device.deactivate();
  result.oscillation_m = result.faulted ? std::numeric_limits<double>::infinity() : (hi - lo).maxCoeff();
  return result;
}

}  // namespace hapticlab
