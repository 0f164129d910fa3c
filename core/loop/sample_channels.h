#pragma once
// The names of a logged sample's channels, with units, in the one order
// every HapticLab sample table uses: the database's chunks
// (db/sample_codec.h), `export`, `sim run`, the SQL extension and the Python
// reader (python/hapticlab_db.py, checked against this list by its test).
// A sample table is long: one row per instrument and update, the key
// columns (instrument 0 left / 1 right, tick) first, then these.
#include <array>

namespace hapticlab {

inline constexpr std::array<const char*, 28> kSampleChannelNames = {
    "dt_s",           "t_s",
    "raw_insertion_m", "raw_pitch_rad", "raw_yaw_rad", "raw_twist_rad", "raw_grip_rad",
    "degraded_insertion_m", "degraded_pitch_rad", "degraded_yaw_rad",
    "tip_x_m",        "tip_y_m",        "tip_z_m",
    "tip_vx_m_per_s", "tip_vy_m_per_s", "tip_vz_m_per_s",
    "ve_force_x_N",   "ve_force_y_N",   "ve_force_z_N",
    "displayed_force_x_N", "displayed_force_y_N", "displayed_force_z_N",
    "insertion_force_N", "pitch_torque_Nm", "yaw_torque_Nm",
    "engine_status",  "device_status",  "in_contact"};

}  // namespace hapticlab
