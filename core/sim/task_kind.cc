#include "core/sim/task_kind.h"

#include <stdexcept>
#include <string>

namespace hapticlab {

const char* to_string(TaskKind task) noexcept {
  return task == TaskKind::kDissection ? "dissection" : "clip";
}

TaskKind parse_task_kind(std::string_view name) {
  if (name == "dissection") return TaskKind::kDissection;
  if (name == "clip") return TaskKind::kClip;
  throw std::invalid_argument("task: '" + std::string(name) + "' is not a task; choose dissection or clip");
}

}  // namespace hapticlab
