#pragma once
// How a trial of a session ended, as its stored outcome says it: the loop's
// stop reason (and the operator's abort, the safety trip, the device's own
// fault detail) turned into the trial's status and abort reason, and
// whether the end is a device fault that ends the session.

#include <optional>
#include <string>

#include "core/device/device.h"
#include "core/loop/haptic_loop.h"
#include "core/sim/trial_runner.h"
#include "db/sample_writer.h"

namespace hapticlab::sessions {

struct TrialEnd {
  // The device, the machine or the rate failed: the session ends after this
  // trial (re-queued) with device_fault_reason.
  bool device_fault = false;
  std::string device_fault_reason;
  bool stopped_by_operator = false;  // the operator's STOP (not an abort of this trial)
};

// Host watchdog trips (not the device's own hang) in a row that end the
// session: the machine cannot keep the loop's timing.
inline constexpr int kMaxWatchdogTripsInARow = 3;

// What the operator is told of the watchdog's halt as it happens: zero
// force only if the device confirmed it (Device::halt_unconfirmed; an
// isolated plugin's frozen host cannot).
std::string watchdog_halt_words(const Device& device);

// Sets outcome.status and outcome.abort_reason from how `loop` stopped, and
// adds the operator's stop to outcome.closing_events. `operator_abort`: the
// reason of an abort of this trial the operator gave, if any.
// `watchdog_trips_in_a_row` counts host watchdog trips across trials (reset
// by any other end). `max_trial_s` names the time limit in its reason.
TrialEnd classify_trial_end(const HapticLoop& loop, const Device& device, std::int64_t trial_id,
                            const std::optional<std::string>& operator_abort, double max_trial_s,
                            int& watchdog_trips_in_a_row, db::TrialOutcome& outcome);

// Why a practice trial (training, run by run_sim_trial) ended before its
// task was complete, said as a trial's abort_reason would say it; empty
// when it was done in full.
std::string practice_cut_short_reason(const SimTrialResult& r, double max_trial_s);

}  // namespace hapticlab::sessions
