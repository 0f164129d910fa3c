#pragma once
// The shipped settings files (examples/settings/NAME.json) as tests load
// them, and the same settings with the passivity controller switched on.
#include <string>

#include <nlohmann/json.hpp>

#include "core/settings/settings_json.h"

namespace hapticlab::testing {

inline EngineSettings load_example(const std::string& name) {
  return load_settings_file(std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/" + name + ".json").engine;
}

// Passivity on both axis kinds; a damping cap of 0 keeps the default.
inline EngineSettings with_passivity(EngineSettings s, double max_damping_N_s_per_m = 0.0,
                                     double max_damping_Nm_s_per_rad = 0.0) {
  nlohmann::json j = settings_to_json({"x", "", s});
  j["translation"]["passivity"]["enabled"] = true;
  j["rotation"]["passivity"]["enabled"] = true;
  if (max_damping_N_s_per_m > 0) j["translation"]["passivity"]["max_damping_N_s_per_m"] = max_damping_N_s_per_m;
  if (max_damping_Nm_s_per_rad > 0)
    j["rotation"]["passivity"]["max_damping_Nm_s_per_rad"] = max_damping_Nm_s_per_rad;
  return settings_from_json(j, "with passivity").engine;
}

}  // namespace hapticlab::testing
