#include "console/console_tuning.h"

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <stdexcept>

#include "console/console_conflict.h"
#include "console/served_file.h"
#include "sessions/trial_end.h"
#include "core/common/utc_time.h"
#include "core/common/output_file.h"

namespace hapticlab::console {
namespace {

constexpr std::size_t kLogEntries = 200;  // kept for the page; the file has them all
// The simulated participant of a free trial: one fixed person who has
// practised the task (participant.h's learning curve has flattened by then).
constexpr std::uint64_t kPilotParticipantSeed = 1;
constexpr int kPilotPracticeTrials = 10;

// The JSON value at a dotted path of a settings object, or null when the
// path names nothing there.
nlohmann::json* at_path(nlohmann::json& j, const std::string& path) {
  nlohmann::json* node = &j;
  std::size_t start = 0;
  for (;;) {
    const std::size_t dot = path.find('.', start);
    const std::string key = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!node->is_object() || !node->contains(key)) return nullptr;
    node = &(*node)[key];
    if (dot == std::string::npos) return node;
    start = dot + 1;
  }
}

}  // namespace

ConsoleTuning::ConsoleTuning(ConsoleTuningConfig config, DeviceHealth& device)
    : config_(std::move(config)), device_(device), live_(config_.live_rate_Hz, config_.live_window_s) {
  if (!(config_.max_s > 0.0)) throw std::invalid_argument("tuning: max_s must be > 0");
  if (!(config_.device_hang_grace_s > 0.0)) throw std::invalid_argument("tuning: device_hang_grace_s must be > 0");
  // Until a trial starts from a setting: every block off, every field at its documented default.
  const NamedSettings none = settings_from_json_text(R"({"name": "No degradation"})", "tuning");
  settings_ = settings_to_json(none);
  engine_ = none.engine;
}

ConsoleTuning::~ConsoleTuning() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

bool ConsoleTuning::running() const {
  std::lock_guard lock(mutex_);
  return running_;
}

void ConsoleTuning::start(const std::string& task, const NamedSettings& from) {
  const TaskKind kind = [&] {
    try {
      return parse_task_kind(task);
    } catch (const std::exception& e) {
      throw std::invalid_argument(std::string("task: ") + e.what());
    }
  }();
  std::lock_guard lock(mutex_);
  if (running_) throw std::invalid_argument("a free trial is running; stop it first");
  device_.check_usable("free trial");
  device_.clear_alert();
  if (thread_.joinable()) thread_.join();
  stop_.store(false);
  running_ = true;
  task_ = task;
  from_name_ = from.name;
  settings_ = settings_to_json(from);
  engine_ = from.engine;
  changed_ = false;
  free_trial_ = 0;
  elapsed_s_ = 0.0;
  error_.clear();
  last_timing_.reset();
  live_.clear();
  append_log("start", "", task + " from '" + from.name + "'");
  thread_ = std::thread(&ConsoleTuning::run, this, kind);
}

void ConsoleTuning::stop() { stop_.store(true); }

void ConsoleTuning::wait_until_ended() {
  if (thread_.joinable()) thread_.join();
}

void ConsoleTuning::set(const std::string& field, const nlohmann::json& value) {
  std::lock_guard lock(mutex_);
  nlohmann::json edited = settings_;
  nlohmann::json* node = field.empty() || field == "name" || field == "description" ? nullptr : at_path(edited, field);
  if (node == nullptr || node->is_object())
    throw std::invalid_argument("field: '" + field + "' is not a settings field (docs/settings.md lists them)");
  const bool is_switch = field.ends_with(".enabled");
  if (is_switch ? !value.is_boolean() : !value.is_number())
    throw std::invalid_argument("field '" + field + "': " + value.dump() + " is not " +
                                (is_switch ? "true or false" : "a number"));
  const std::string before = node->dump();
  *node = value;
  // A tuned device preset is no longer the device its source describes.
  edited.erase("source");
  NamedSettings parsed;
  try {
    // The loader's own checks: the field, its value and the allowed range.
    parsed = settings_from_json(edited, "tuning");
  } catch (const SettingsError& e) {
    throw std::invalid_argument(e.what());
  }
  // A change is made to a loop: before Start it would be replaced by the
  // setting Start loads, after the end no loop would run with it, and the
  // log would file it under a repetition that never had it.
  if (!running_)
    throw ConsoleConflict("no free trial is running: a change is made to a running free trial (Start loads the "
                          "chosen setting afresh; Save keeps what the last one ran with)");
  // Logged before it is made: a change the pilot's record cannot hold is
  // not made (the page says why), rather than made and missing from it.
  if (const std::string failed = append_log(field, before, value.dump(), false); !failed.empty())
    throw std::runtime_error("the change of '" + field + "' was not made: " + failed);
  settings_ = std::move(edited);
  engine_ = parsed.engine;
  changed_ = true;
  applied_t_s_.reset();  // until the loop has this change too
}

std::string ConsoleTuning::append_log(const std::string& field, const std::string& from, const std::string& to,
                                      bool happened) {
  const double loop_t_s = running_ ? live_.newest_t_s() : 0.0;
  nlohmann::json entry = {{"utc", utc_now_iso8601()}, {"free_trial", free_trial_}, {"loop_t_s", loop_t_s},
                          {"field", field}, {"from", from}, {"to", to}};
  const auto keep = [&] {
    log_.push_back(entry);
    if (log_.size() > kLogEntries) log_.erase(log_.begin());
  };
  // The whole log in a file beside the saved settings: a pilot's record.
  std::error_code ec;
  std::filesystem::create_directories(config_.out_dir, ec);
  const std::filesystem::path path = config_.out_dir / "tuning-log.csv";
  const bool fresh = !std::filesystem::exists(path);
  std::ofstream out(path, std::ios::app);
  if (fresh) out << "utc,free_trial,loop_t_s,field,from,to\n";
  auto quoted = [](const std::string& s) {
    std::string q = "\"";
    for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + '"';
  };
  out << entry["utc"].get<std::string>() << ',' << free_trial_ << ',' << loop_t_s << ',' << quoted(field) << ','
      << quoted(from) << ',' << quoted(to) << '\n';
  out.close();  // the line reaches the file here: checked after, not before
  if (out) {
    keep();
    return {};
  }
  const std::string failed = "cannot append to " + path.string() + " (disk full?)";
  if (!happened) return failed;  // not made: nothing is missing from the log
  keep();
  error_ = failed + ": the tuning log is incomplete";
  return failed;
}

std::string ConsoleTuning::save(const std::string& name) {
  if (name.empty() || name.size() > 64)
    throw std::invalid_argument("name: " + std::to_string(name.size()) + " characters, must be 1..64");
  std::string file;
  for (char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (std::isalnum(u)) file += static_cast<char>(std::tolower(u));
    else if (c == '+' || c == '-') file += '-';
    else if (c == ' ' || c == '_' || c == '.') file += '_';
    else throw std::invalid_argument("name: '" + name + "' may hold letters, digits, ' ', '_', '-', '+' and '.' only");
  }
  file += ".json";
  std::lock_guard lock(mutex_);
  const std::filesystem::path path = config_.out_dir / file;
  if (std::filesystem::exists(path))
    throw std::invalid_argument("name: " + path.string() + " exists; choose another name");
  NamedSettings named = settings_from_json(settings_, "tuning");
  named.name = name;
  named.description = "Tuned in the HapticLab console (" + utc_now_iso8601() + "), starting from '" + from_name_ + "'.";
  std::error_code ec;
  std::filesystem::create_directories(config_.out_dir, ec);
  try {
    write_file_atomically(path, settings_to_json(named).dump(2) + "\n");
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("save: ") + e.what());
  }
  saved_.push_back(file);
  append_log("save", "", file);
  return file;
}

bool ConsoleTuning::poll_free_trial(SimRig& rig, int repetition, int& polls, bool& alerted) {
  HapticLoop& loop = rig.loop();
  if (!alerted && loop.watchdog_tripped()) {
    // At once, as a session's runner does: the loop is halted, and a
    // call that does not return is given up on after the grace.
    alerted = true;
    const DeviceCall call = loop.watchdog_call();
    char limit[32];
    std::snprintf(limit, sizeof limit, "%.0f ms", 1e3 * loop.watchdog_limit_s());
    device_.alert((call != DeviceCall::kNone
                       ? "device " + std::string(to_string(call)) + "() has not returned for " + limit
                       : "the haptic loop has completed no update for " + std::string(limit)) +
                  " in free trial " + std::to_string(repetition) + "; the watchdog halted the device (zero force)");
  }
  std::lock_guard lock(mutex_);
  if (changed_) {
    rig.engine().set_settings(engine_);  // taken by the loop at its next update
    changed_ = false;
    applied_t_s_ = rig.loop().elapsed_s();
  }
  if (++polls % 500 == 0) last_timing_ = rig.loop().timing();  // ~100 µs: about every 0.1 s
  return !stop_.load();
}

std::optional<SimTrialConfig> ConsoleTuning::next_repetition(TaskKind task, int& repetition) {
  SimTrialConfig c;
  {
    std::lock_guard lock(mutex_);
    if (elapsed_s_ >= config_.max_s) return std::nullopt;
    repetition = ++free_trial_;
    live_.clear();
    c.settings = engine_;
    if (changed_ || applied_t_s_) applied_t_s_ = 0.0;  // every change is in from the start
    changed_ = false;
    c.trial_seed = static_cast<std::uint64_t>(free_trial_);
    c.max_duration_s = config_.max_s - elapsed_s_;
  }
  c.task = task;
  c.device = config_.device;
  c.participant_seed = kPilotParticipantSeed;
  c.population = config_.population;
  c.practice_trials = kPilotPracticeTrials;
  c.clock = config_.clock;
  c.rate_Hz = config_.rate_Hz;
  c.realtime = config_.realtime;
  c.safety = config_.protections;
  return c;
}

bool ConsoleTuning::goes_on_after(const SimTrialResult& r, int repetition, bool alerted, int& host_trips_in_a_row,
                                  std::string& error) {
  if (r.device_hung) {
    char hung[32];
    std::snprintf(hung, sizeof hung, "%.0f ms", 1e3 * r.hung_s);
    error = "device " + std::string(to_string(r.hung_call)) + " hung for " + hung + " in free trial " +
            std::to_string(repetition) + " and had not returned when the console gave up on it (zero force since " +
            "the watchdog halted it)";
    device_.mark_hung(error);
    return false;
  }
  // A trip the polls missed (the loop ended before the next): said now,
  // never not at all.
  if (!alerted && r.stop_reason == StopReason::kWatchdog)
    device_.alert("the watchdog halted the device (zero force) in free trial " + std::to_string(repetition) + ": " +
                  describe(r.safety_trip));
  std::lock_guard lock(mutex_);
  elapsed_s_ += r.duration_s;
  last_timing_ = r.timing;
  if (r.device_refused) {
    error = "the device could not be activated (" + std::string(to_string(r.device_status)) + ")";
    return false;
  }
  if (r.stop_reason == StopReason::kWatchdog && r.safety_trip.kind != SafetyTripKind::kDeviceCallHung) {
    // The host fell behind (a late update, a stalled step), as a session's
    // trial can: zero force was commanded and the alert shown; this
    // repetition ended, logged, and the free trial goes on with the next,
    // unless it keeps happening (as a session does).
    append_log("watchdog", "", describe(r.safety_trip));
    if (++host_trips_in_a_row < sessions::kMaxWatchdogTripsInARow) return true;
    error = "the free trial stopped: watchdog (zero force), " + std::to_string(host_trips_in_a_row) +
            " repetitions in a row; this machine cannot keep the loop's timing now";
    return false;
  }
  host_trips_in_a_row = 0;
  if (r.stop_reason != StopReason::kTaskComplete && r.stop_reason != StopReason::kStopRequested &&
      r.stop_reason != StopReason::kMaxDuration) {
    error = std::string("the free trial stopped: ") + to_string(r.stop_reason) + " (zero force)";
    return false;
  }
  return true;
}

void ConsoleTuning::run(TaskKind task) {
  std::string error;
  int host_trips_in_a_row = 0;
  try {
    while (!stop_.load()) {
      int repetition = 0;
      const std::optional<SimTrialConfig> c = next_repetition(task, repetition);
      if (!c) break;
      SimTrialSink sink;
      sink.on_sample = [this](const LoopSample& s) {
        std::lock_guard lock(mutex_);
        live_.add({&s, 1});
      };
      int polls = 0;
      bool alerted = false;
      sink.device_hang_grace_s = config_.device_hang_grace_s;
      sink.between_drains = [this, &polls, &alerted, repetition](SimRig& rig) {
        return poll_free_trial(rig, repetition, polls, alerted);
      };
      if (!goes_on_after(run_sim_trial(*c, sink), repetition, alerted, host_trips_in_a_row, error)) break;
    }
  } catch (const std::exception& e) {
    error = e.what();
  }
  std::lock_guard lock(mutex_);
  if (!error.empty()) error_ = error;
  append_log("stop", "", error.empty() ? "" : error);
  running_ = false;
}

nlohmann::json ConsoleTuning::status() const {
  std::lock_guard lock(mutex_);
  nlohmann::json j = {{"running", running_}, {"task", task_},       {"from", from_name_},
                      {"settings", settings_}, {"free_trial", free_trial_}, {"log", log_},
                      {"saved", saved_},     {"error", error_}};
  j["rate_Hz"] = config_.rate_Hz;
  j["rate_tolerance_fraction"] = config_.protections.rate.tolerance_fraction;
  if (running_) j["loop_t_s"] = live_.newest_t_s();
  if (running_ && applied_t_s_) j["applied_t_s"] = *applied_t_s_;
  j.update(device_.status());
  if (last_timing_ && last_timing_->mean_period_s > 0)
    j["loop"] = {{"rate_Hz", 1.0 / last_timing_->mean_period_s},
                 {"p99_period_ms", 1e3 * last_timing_->p99_period_s},
                 {"max_period_ms", 1e3 * last_timing_->max_period_s},
                 {"overruns", last_timing_->overruns}};
  return j;
}

std::array<std::vector<LivePoint>, 2> ConsoleTuning::live_since(double after_t_s) const {
  std::lock_guard lock(mutex_);
  return live_.since(after_t_s);
}

std::optional<std::filesystem::path> ConsoleTuning::file(const std::string& name) const {
  return served_file(config_.out_dir, name);
}

nlohmann::json ConsoleTuning::reference() {
  nlohmann::json fields = nlohmann::json::array();
  for (const SettingsFieldInfo& f : settings_field_reference())
    fields.push_back({{"path", f.path}, {"default", f.default_value}, {"min", f.lo}, {"max", f.hi},
                      {"min_exclusive", f.lo_exclusive}});
  return {{"fields", fields}};
}

}  // namespace hapticlab::console
