#pragma once
// The console's device, as the session and the free trial found it. A
// device call that does not return for the loop watchdog's time is an alert
// the operator sees at once (the status and the page's stream carry it,
// the console's stderr says it). One that still has not returned after the
// grace period makes the device hung for the console's lifetime: the
// haptic loop's thread is still inside the device's code (an in-process
// plugin), its rig was left to it, and opening the device again could run a
// second instance of the same hardware beside it. Every later session or
// free trial is refused, saying so, and the console ends with exit status 3
// (app/study/console_command.cc), without waiting for that thread.

#include <mutex>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace hapticlab::console {

class DeviceHealth {
 public:
  // Thread-safe, all of them.

  // A device call has not returned for the watchdog's time (the watchdog
  // halted the device): `text` says which, and in what. Kept (with the
  // wall time) until clear_alert().
  void alert(const std::string& text);
  // A new session or free trial: an old alert no longer describes it.
  void clear_alert();
  // The call never returned: the device is unusable until the console is
  // restarted. The first `why` is kept.
  void mark_hung(const std::string& why);
  std::optional<std::string> hung() const;
  // Throws ConsoleConflict (console_conflict.h) when the device hung,
  // naming `what` was refused, the hang and what to do.
  void check_usable(const std::string& what) const;
  // {"device_alert": "...", "device_alert_utc": "...", "device_hung": "..."}
  // with the members that apply (none: {}).
  nlohmann::json status() const;

 private:
  mutable std::mutex mutex_;
  std::optional<std::string> alert_;
  std::string alert_utc_;
  std::optional<std::string> hung_;
};

}  // namespace hapticlab::console
