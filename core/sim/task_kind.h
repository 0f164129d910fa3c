#pragma once
// The simulated workstation's tasks (the thesis' 3.3.2): their names in
// protocols and files, and the enum the simulation selects a task VE by.
// A task of a lab's own VE needs none of this: the loop only knows the
// VirtualEnvironment contract (core/loop/virtual_environment.h).
#include <cstdint>
#include <string_view>

namespace hapticlab {

enum class TaskKind : std::uint8_t { kDissection = 0, kClip = 1 };
// "dissection" or "clip".
const char* to_string(TaskKind task) noexcept;
// "dissection" or "clip"; throws std::invalid_argument naming the value and
// the choices otherwise.
TaskKind parse_task_kind(std::string_view name);

}  // namespace hapticlab
