#include "analysis/metrics/device_energy.h"

#include <cmath>

#include "core/engine/joint_transform.h"

namespace hapticlab::analysis {
namespace {

void add_work(AxisEnergy& e, double work_J) {
  if (work_J > 0.0)
    e.out_J += work_J;
  else
    e.in_J -= work_J;
}

}  // namespace

double HandEnergy::device_out_J() const { return device[0].out_J + device[1].out_J + device[2].out_J; }
double HandEnergy::device_in_J() const { return device[0].in_J + device[1].in_J + device[2].in_J; }
double HandEnergy::engine_out_J() const { return engine[0].out_J + engine[1].out_J + engine[2].out_J; }
double HandEnergy::engine_in_J() const { return engine[0].in_J + engine[1].in_J + engine[2].in_J; }

void EnergyAccumulator::start() {
  energy_ = HandEnergy{};
  have_any_ = false;
  previous_finite_ = false;
}

void EnergyAccumulator::add(const std::array<double, 5>& raw_position, const std::array<double, 3>& joint_force,
                            const std::array<double, 3>& ve_force_N) {
  bool finite = true;
  for (int j = 0; j < 3; ++j) {
    finite = finite && std::isfinite(raw_position[j]) && std::isfinite(joint_force[j]) && std::isfinite(ve_force_N[j]);
  }
  if (have_any_) {
    // The interval from the previous update to this one.
    if (finite && previous_finite_) {
      ++energy_.intervals;
      for (int j = 0; j < 3; ++j) {
        const double dq = raw_position[j] - q_[j];
        add_work(energy_.device[j], f_[j] * dq);
        add_work(energy_.engine[j], (f_[j] - f_ve_[j]) * dq);
      }
    } else {
      ++energy_.skipped;
    }
  }
  have_any_ = true;
  previous_finite_ = finite;
  if (!finite) return;
  // Out of contact the VE force is exactly zero (most updates): no pose to
  // compute, which is most of this function's cost.
  const bool touching = ve_force_N[0] != 0.0 || ve_force_N[1] != 0.0 || ve_force_N[2] != 0.0;
  const JointVector f_ve =
      touching ? world_to_joint(tool_pose(raw_position[0], pitch_(raw_position[1]), yaw_(raw_position[2])),
                                Eigen::Vector3d(ve_force_N[0], ve_force_N[1], ve_force_N[2]))
               : JointVector::Zero();
  for (int j = 0; j < 3; ++j) {
    q_[j] = raw_position[j];
    f_[j] = joint_force[j];
    f_ve_[j] = f_ve[j];
  }
}

}  // namespace hapticlab::analysis
