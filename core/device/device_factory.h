#pragma once
// Opens the device a DeviceSpec names (device_spec.h): constructs it and
// checks its options. The caller configures and activates it.

#include <memory>

#include "core/device/device.h"
#include "core/device/device_spec.h"

namespace hapticlab {

// Throws std::invalid_argument for an unknown option, std::runtime_error
// when the device cannot be opened (a plugin file missing or of another
// ABI version, ...), with a message for the operator.
std::unique_ptr<Device> open_device(const DeviceSpec& spec);

}  // namespace hapticlab
