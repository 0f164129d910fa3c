#pragma once
// One haptic-loop update as it leaves the loop for the logger: plain,
// trivially copyable data so it can travel through the lock-free queue.
//
// Frames and units: positions of the tool tip and forces are in the VE world
// frame (core/loop/workspace.h) [m, m/s, N]; joints follow DeviceJoint order
// (insertion m, pitch/yaw/twist/grip rad); joint forces are insertion N,
// pitch/yaw N·m.

#include <array>
#include <cstdint>
#include <type_traits>

namespace hapticlab {

using Vec3 = std::array<double, 3>;

struct InstrumentSample {
  std::array<double, 5> raw_position{};       // as read from the device
  std::array<double, 3> degraded_position{};  // as sent to the VE (insertion, pitch, yaw)
  Vec3 tip_position_m{};                      // VE tool tip (from the degraded joints)
  Vec3 tip_velocity_m_per_s{};                // its velocity, low-pass filtered
  Vec3 ve_force_N{};                          // tissue force on the tip, from the VE
  Vec3 displayed_force_N{};                   // what the engine asked the device to display
  std::array<double, 3> joint_force{};        // commanded: insertion N, pitch/yaw N·m
  std::uint32_t engine_status = 0;            // StatusFlag bits (core/engine/status.h)
  bool in_contact = false;
};

struct LoopSample {
  std::uint64_t tick = 0;      // 0-based update number
  double t_s = 0.0;            // loop clock at the start of the update
  double dt_s = 0.0;           // measured time since the previous update
  std::int32_t device_status = 0;  // DeviceStatus of the read
  std::array<InstrumentSample, 2> instrument{};
};

static_assert(std::is_trivially_copyable_v<LoopSample>);

}  // namespace hapticlab
