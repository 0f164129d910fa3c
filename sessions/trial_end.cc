#include "sessions/trial_end.h"

#include "core/common/csv_format.h"
#include "core/loop/task_event.h"
#include "sessions/study_session.h"

namespace hapticlab::sessions {
namespace {

// The device's own fault, said as specifically as the device can.
// A live device (a plugin, a driver) that answers "end of data": named as
// such rather than as "device fault: ok" (its status stays ok).
constexpr const char* kLiveEndOfDataReason =
    "device fault: end_of_data: the device said its data ran out, which only a replay may say";

std::string device_fault_reason(const HapticLoop& loop, const Device& device) {
  if (loop.device_status() == DeviceStatus::kTimeout) {
    // "device_timeout" first, so a query can match the reason's start.
    const std::string detail = device.fault_detail();
    return std::string(to_string(DeviceStatus::kTimeout)) + (detail.empty() ? "" : ": " + detail);
  }
  if (const std::string detail = device.fault_detail();
      !detail.empty() && (loop.device_status() == DeviceStatus::kDeviceCrashed ||
                          loop.device_status() == DeviceStatus::kDeviceHung)) {
    // An isolated plugin's process: the device names it in full
    // ("device_crashed: SIGSEGV in read", "device read hung for 15 ms").
    return detail;
  }
  // Any other fault, with what the device knows of its first failure when
  // it knows more than the status ("device fault: read_failed: the plugin's
  // read returned 42, ...").
  const std::string detail = device.status_detail();
  return std::string("device fault: ") + to_string(loop.device_status()) + (detail.empty() ? "" : ": " + detail);
}

// The host fell behind (a late update, a stalled step, a slow writer): zero
// force was commanded, the trial is re-queued and the session goes on,
// unless it keeps happening -- or the device did not confirm the halt, so
// it may still be powered.
void watchdog_end(const SafetyTrip& trip, int& watchdog_trips_in_a_row, TrialEnd& end, db::TrialOutcome& outcome) {
  outcome.status = db::TrialStatus::kAborted;
  outcome.abort_reason = "watchdog: " + describe(trip);
  if (trip.halt_unconfirmed) {
    end.device_fault = true;
    end.device_fault_reason = outcome.abort_reason;
  } else if (++watchdog_trips_in_a_row >= kMaxWatchdogTripsInARow) {
    end.device_fault = true;
    end.device_fault_reason = outcome.abort_reason + " (" + std::to_string(kMaxWatchdogTripsInARow) +
                              " trials in a row; this machine cannot keep the loop's timing now)";
  }
}

}  // namespace

std::string watchdog_halt_words(const Device& device) {
  return device.halt_unconfirmed()
             ? "the watchdog sent the device a halt, which it has not confirmed: it may still hold its last force "
               "(switch its amplifiers off)"
             : "the watchdog halted the device (zero force)";
}

TrialEnd classify_trial_end(const HapticLoop& loop, const Device& device, std::int64_t trial_id,
                            const std::optional<std::string>& operator_abort, double max_trial_s,
                            int& watchdog_trips_in_a_row, db::TrialOutcome& outcome) {
  TrialEnd end;
  const auto fault = [&](std::string reason) {
    outcome.status = db::TrialStatus::kAborted;
    outcome.abort_reason = reason;
    end.device_fault = true;
    end.device_fault_reason = std::move(reason);
  };
  const StopReason stop = loop.stop_reason();
  if (stop != StopReason::kWatchdog) watchdog_trips_in_a_row = 0;
  if (stop == StopReason::kStopRequested && operator_abort) {
    // Ended by the operator's abort (its event is in closing_events);
    // re-queued, and the session goes on.
    outcome.status = db::TrialStatus::kAborted;
    outcome.abort_reason = "operator abort: " + *operator_abort;
    return end;
  }
  switch (stop) {
    case StopReason::kTaskComplete: outcome.status = db::TrialStatus::kComplete; break;
    case StopReason::kStopRequested:
      // The operator's action is part of the trial's record, at the loop
      // time it took effect, after the VE's events of that update (the
      // writer may still hold them now).
      outcome.closing_events.push_back({trial_id, loop.elapsed_s(), to_string(TaskEventType::kOperatorAbort), -1, 0,
                                        std::string(kOperatorStopReason)});
      outcome.status = db::TrialStatus::kAborted;
      outcome.abort_reason = kOperatorStopReason;
      end.stopped_by_operator = true;
      break;
    case StopReason::kMaxDuration:
      outcome.status = db::TrialStatus::kAborted;
      outcome.abort_reason = time_limit_reason(format_number(max_trial_s) + " s");
      break;
    case StopReason::kSafetyLimit:
      // Zero force was commanded; re-queued like a device fault.
      fault("safety limit: " + describe(loop.safety_trip()));
      break;
    case StopReason::kRateViolation:
      // The rate is a controlled variable: the trial measured another
      // condition. Re-queued; a device that cannot keep the rate will not
      // keep it in the next trial either, so the session ends.
      fault("rate_violation: " + describe(loop.safety_trip()));
      break;
    case StopReason::kWatchdog:
      if (loop.safety_trip().kind == SafetyTripKind::kDeviceCallHung) {
        // The device's own call hung: a device fault, as a timeout is.
        fault(describe(loop.safety_trip()));
        break;
      }
      watchdog_end(loop.safety_trip(), watchdog_trips_in_a_row, end, outcome);
      break;
    case StopReason::kEndOfData:  // a replay's normal end; from a live device, a status it must not give
      fault(kLiveEndOfDataReason);
      break;
    default: fault(device_fault_reason(loop, device)); break;
  }
  // The trial's data is what it is; but a device that was not set to zero
  // force or not switched off as the trial ended may still be powered: the
  // session ends (exit 3), and the trial's record says so.
  if (loop.shutdown_status() != DeviceStatus::kOk && !end.device_fault) {
    const std::string reason = "device " + std::string(to_string(loop.shutdown_call())) + "() failed (" +
                               to_string(loop.shutdown_status()) + ") as trial " + std::to_string(trial_id) +
                               " ended: the device may still be powered; check it before the next session";
    outcome.closing_events.push_back({trial_id, loop.elapsed_s(), "device_shutdown_fault", -1, 0, reason});
    end.device_fault = true;
    end.device_fault_reason = reason;
  }
  return end;
}

std::string practice_cut_short_reason(const SimTrialResult& r, double max_trial_s) {
  if (r.task_complete) return {};
  switch (r.stop_reason) {
    case StopReason::kMaxDuration: return time_limit_reason(format_number(max_trial_s) + " s");
    case StopReason::kSafetyLimit: return "safety limit: " + describe(r.safety_trip);
    case StopReason::kRateViolation: return "rate_violation: " + describe(r.safety_trip);
    case StopReason::kWatchdog:
      return r.safety_trip.kind == SafetyTripKind::kDeviceCallHung ? describe(r.safety_trip)
                                                                   : "watchdog: " + describe(r.safety_trip);
    case StopReason::kDeviceFault: return std::string("device fault: ") + to_string(r.device_status);
    case StopReason::kStopRequested: return "operator stopped the session";
    default: return std::string("ended before the task was complete (") + to_string(r.stop_reason) + ")";
  }
}

}  // namespace hapticlab::sessions
