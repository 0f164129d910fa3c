#pragma once
// Things that happen in a task, reported by the virtual environment with the
// time of the update that produced them. Logged next to the samples and used
// by the analysis (completion time starts at the first 20 mm insertion and
// ends at the last tissue contact, thesis 3.3.5.1).

#include <array>
#include <cstdint>

namespace hapticlab {

enum class TaskEventType : std::uint8_t {
  kInsertionPassed = 0,  // the tool's insertion rose through 20 mm
  kInsertionWithdrawn,   // ... and fell back below it
  kContactStart,         // the tip started touching tissue
  kContactEnd,           // ... and stopped
  kGraspStart,           // a closed grasper holds tissue or the duct
  kGraspEnd,
  kTissueRemoved,        // dissection: a patch of covering tissue is gone (index = cell)
  kClipApplied,          // clip: index = clip number 0..2
  kClipMissed,           // clip: jaws closed but no clip was registered
  kTaskComplete,
  kOperatorAbort,        // the operator stopped the trial (logged by the runner)
};
inline constexpr int kNumTaskEventTypes = 11;

// Stable snake_case names, used in CSV files and the database.
const char* to_string(TaskEventType type) noexcept;

struct TaskEvent {
  double t_s = 0.0;
  TaskEventType type = TaskEventType::kContactStart;
  std::int8_t instrument = -1;  // 0 left, 1 right, -1 for the task as a whole
  std::int32_t index = 0;       // cell or clip number, where it applies
};

// Events of one update. Fixed capacity so the real-time path never
// allocates; more events than that in one update are counted, not stored.
class EventBuffer {
 public:
  static constexpr int kCapacity = 16;
  void clear() noexcept { size_ = 0; overflow_ = 0; }
  void push(const TaskEvent& e) noexcept {
    if (size_ < kCapacity) events_[static_cast<std::size_t>(size_++)] = e;
    else ++overflow_;
  }
  int size() const noexcept { return size_; }
  int overflow() const noexcept { return overflow_; }
  const TaskEvent& operator[](int i) const noexcept { return events_[static_cast<std::size_t>(i)]; }

 private:
  std::array<TaskEvent, kCapacity> events_{};
  int size_ = 0;
  int overflow_ = 0;
};

}  // namespace hapticlab
