#include "console/device_health.h"

#include <cstdio>

#include "console/console_conflict.h"
#include "core/common/utc_time.h"

namespace hapticlab::console {

void DeviceHealth::alert(const std::string& text) {
  {
    std::lock_guard lock(mutex_);
    alert_ = text;
    alert_utc_ = utc_now_iso8601();
  }
  // At once, also where no page watches (the console's terminal).
  std::fprintf(stderr, "hapticlab console: %s\n", text.c_str());
  std::fflush(stderr);
}

void DeviceHealth::clear_alert() {
  std::lock_guard lock(mutex_);
  alert_.reset();
  alert_utc_.clear();
}

void DeviceHealth::mark_hung(const std::string& why) {
  {
    std::lock_guard lock(mutex_);
    if (hung_) return;
    hung_ = why;
  }
  std::fprintf(stderr,
               "hapticlab console: the device hung: %s\nhapticlab console: no session or free trial can use it "
               "until the console is restarted (it ends with exit status 3)\n",
               why.c_str());
  std::fflush(stderr);
}

std::optional<std::string> DeviceHealth::hung() const {
  std::lock_guard lock(mutex_);
  return hung_;
}

void DeviceHealth::check_usable(const std::string& what) const {
  std::lock_guard lock(mutex_);
  if (hung_)
    throw ConsoleConflict(what + ": refused, the device hung (" + *hung_ +
                          "); its code may still be running in this console, so it cannot be opened again: stop the "
                          "console (Ctrl-C; it exits with status 3), restart the device, then start the console again");
}

nlohmann::json DeviceHealth::status() const {
  std::lock_guard lock(mutex_);
  nlohmann::json j = nlohmann::json::object();
  if (alert_) {
    j["device_alert"] = *alert_;
    j["device_alert_utc"] = alert_utc_;
  }
  if (hung_) j["device_hung"] = *hung_;
  return j;
}

}  // namespace hapticlab::console
