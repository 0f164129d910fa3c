#pragma once
// The virtual environment (VE) side of the haptic loop: it receives the
// degraded instrument positions and returns the tissue force on each tool
// tip, in the world frame, plus task events.
//
// HapticLab ships two simulated VEs, the thesis' tasks (3.3.2): dissection
// and clip application. A user's own VE connects through the C API instead;
// this interface is for VEs that run inside the loop.

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "core/device/device.h"
#include "core/loop/task_event.h"

namespace hapticlab {

struct VeInput {
  double t_s = 0.0;
  double dt_s = 0.0;
  // Per instrument: insertion/pitch/yaw as degraded by the engine, twist and
  // grip as read from the device (the engine does not degrade them).
  std::array<DeviceJoints, 2> joints{};
  // Per instrument: the tool tip in the VE world frame [m] from the degraded
  // joints (tip_world of joints), worked out once by whoever fills joints.
  std::array<Eigen::Vector3d, 2> tip_m{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
};

struct VeOutput {
  std::array<Eigen::Vector3d, 2> tip_force_N{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  // Torque on the handle grip [N·m] (the thesis' VE pushes back in the
  // handle when a clip is applied); positive opens the grip.
  std::array<double, 2> grip_torque_Nm{0.0, 0.0};
  std::array<bool, 2> in_contact{false, false};
};

class VirtualEnvironment {
 public:
  virtual ~VirtualEnvironment() = default;
  // Real-time thread: no allocation, locks, I/O or exceptions.
  virtual void step(const VeInput& in, VeOutput& out, EventBuffer& events) noexcept = 0;
  virtual bool complete() const noexcept = 0;
};

}  // namespace hapticlab
