#pragma once
// The thesis' clip application task (3.3.2.2): a compliant duct runs between
// two larger structures. The left-hand grasper stabilizes the duct, the
// right-hand clip applier closes a clip on it at the marked spot. Three
// clips go on one duct (3.4.2.2); the task is complete after the third.
//
// The duct is a cylinder whose wall gives way like a spring; held by the
// grasper within stabilization_reach_m of the contact it is stiffer. A clip
// registers when the applier's jaws close with the tip on the duct within
// marker_tolerance_m of the next marker, if the duct is held or the tool
// is still; otherwise it slips off (clip_missed). Like the thesis' VE, it
// also fails to register a correctly placed clip now and then.

#include <array>
#include <cstdint>

#include <Eigen/Core>

#include "core/common/random.h"
#include "core/sim/contact.h"
#include "core/sim/grasp.h"
#include "core/loop/virtual_environment.h"
#include "core/sim/task_kind.h"

namespace hapticlab {

struct ClipParams {
  double duct_z_m = -0.104;          // duct axis height
  double duct_radius_m = 0.0025;
  double duct_half_length_m = 0.035;  // between the two structures
  double base_z_m = -0.114;          // surface of the structures below
  ContactParams duct{150.0, 1.0};          // unstabilized duct wall
  ContactParams duct_held{350.0, 1.5};     // held by the grasper nearby
  ContactParams base{250.0, 2.0};
  GraspParams grasp{150.0, 1.0, 0.02};
  double grasp_reach_m = 0.0015;      // jaws take the duct within radius + this
  double stabilization_reach_m = 0.020;
  double marker_spacing_m = 0.009;
  double marker_tolerance_m = 0.0025;
  double seat_reach_m = 0.0015;       // tip this close to the wall counts as on the duct
  double still_speed_m_per_s = 0.008;  // an unheld duct takes a clip only from a still tool
  double detection_failure = 0.05;    // chance a correct clip is not registered
  double clip_torque_Nm = 0.05;       // handle kick when a clip closes
  double clip_torque_s = 0.15;
};

class ClipTask final : public VirtualEnvironment {
 public:
  static constexpr int kClipsPerDuct = 3;

  explicit ClipTask(std::uint64_t layout_seed, const ClipParams& params = {});

  void step(const VeInput& in, VeOutput& out, EventBuffer& events) noexcept override;
  bool complete() const noexcept override { return clips_applied_ >= kClipsPerDuct; }
  TaskKind kind() const noexcept { return TaskKind::kClip; }

  // --- what a participant can see
  const ClipParams& params() const noexcept { return params_; }
  double duct_y_m() const noexcept { return duct_y_m_; }
  double marker_x_m(int clip) const noexcept { return marker_x_m_[static_cast<std::size_t>(clip)]; }
  int clips_applied() const noexcept { return clips_applied_; }
  int clips_missed() const noexcept { return clips_missed_; }
  const Grasp& grasp() const noexcept { return grasp_; }
  Eigen::Vector3d axis_point(double x_m) const noexcept { return {x_m, duct_y_m_, params_.duct_z_m}; }

 private:
  ClipParams params_;
  Random rng_;
  double duct_y_m_ = 0.0;
  std::array<double, kClipsPerDuct> marker_x_m_{};
  int clips_applied_ = 0;
  int clips_missed_ = 0;
  bool jaws_closed_ = false;
  double torque_until_s_ = -1.0;
  Grasp grasp_;
  ToolTracker tools_;
};

}  // namespace hapticlab
