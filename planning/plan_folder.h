#pragma once
// The output folder of a plan command (plan power, merge, calibrate,
// transfer; also stability map, engine demo, demo and stats learning), made and proven writable before anything
// is simulated: a folder that cannot take the results is found in a
// second, not after the whole simulation.
#include <filesystem>
#include <string>

namespace hapticlab::planning {

// Makes `out` (and its parents) and writes and removes a probe file in it.
// Throws std::runtime_error naming --out, the folder and the cause, ending
// "; " + not_done ("nothing was simulated" for the simulating commands):
// empty, an existing file that is not a folder, cannot be made, cannot be
// written in.
void prepare_plan_folder(const std::filesystem::path& out, const std::string& not_done = "nothing was simulated");

}  // namespace hapticlab::planning
