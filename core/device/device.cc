#include "core/device/device.h"

namespace hapticlab {

const char* to_string(DeviceStatus status) noexcept {
  switch (status) {
    case DeviceStatus::kOk: return "ok";
    case DeviceStatus::kNotConfigured: return "not_configured";
    case DeviceStatus::kNotActive: return "not_active";
    case DeviceStatus::kInvalidConfig: return "invalid_config";
    case DeviceStatus::kReadFailed: return "read_failed";
    case DeviceStatus::kNonFiniteReading: return "non_finite_reading";
    case DeviceStatus::kOutOfRange: return "out_of_range";
    case DeviceStatus::kWriteFailed: return "write_failed";
    case DeviceStatus::kEndOfData: return "end_of_data";
  }
  // A value cast from an integer that names no status (e.g. from the C API).
  return "unknown";
}

}  // namespace hapticlab
