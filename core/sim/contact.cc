#include "core/sim/contact.h"

#include <numbers>

#include "core/loop/workspace.h"

namespace hapticlab {

Eigen::Vector3d ToolTracker::tip_velocity(int instrument, const Eigen::Vector3d& tip_m,
                                          double dt_s) noexcept {
  const auto i = static_cast<std::size_t>(instrument);
  if (have_tip_[i] && dt_s > 0.0) {
    const double alpha = dt_s / (dt_s + 1.0 / (2.0 * std::numbers::pi * 50.0));
    velocity_[i] += alpha * ((tip_m - last_tip_m_[i]) / dt_s - velocity_[i]);
  }
  last_tip_m_[i] = tip_m;
  have_tip_[i] = true;
  return velocity_[i];
}

void ToolTracker::update(int instrument, double t_s, double insertion_m, bool in_contact,
                         EventBuffer& events) noexcept {
  const auto i = static_cast<std::size_t>(instrument);
  const auto tool = static_cast<std::int8_t>(instrument);
  const bool past = insertion_m >= kInsertionMark_m;
  if (past != past_mark_[i]) {
    events.push({t_s, past ? TaskEventType::kInsertionPassed : TaskEventType::kInsertionWithdrawn, tool, 0});
    past_mark_[i] = past;
  }
  if (in_contact != contact_[i]) {
    events.push({t_s, in_contact ? TaskEventType::kContactStart : TaskEventType::kContactEnd, tool, 0});
    contact_[i] = in_contact;
  }
  if (in_contact) last_contact_s_ = t_s;
}

const char* to_string(TaskEventType type) noexcept {
  switch (type) {
    case TaskEventType::kInsertionPassed: return "insertion_passed_20mm";
    case TaskEventType::kInsertionWithdrawn: return "insertion_withdrawn_20mm";
    case TaskEventType::kContactStart: return "contact_start";
    case TaskEventType::kContactEnd: return "contact_end";
    case TaskEventType::kGraspStart: return "grasp_start";
    case TaskEventType::kGraspEnd: return "grasp_end";
    case TaskEventType::kTissueRemoved: return "tissue_removed";
    case TaskEventType::kClipApplied: return "clip_applied";
    case TaskEventType::kClipMissed: return "clip_missed";
    case TaskEventType::kTaskComplete: return "task_complete";
    case TaskEventType::kOperatorAbort: return "operator_abort";
  }
  return "unknown";
}

}  // namespace hapticlab
