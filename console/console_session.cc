#include "console/console_session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <stdexcept>

namespace hapticlab::console {
namespace {

double wall_now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

const char* phase_name(sessions::SessionProgress::Phase p) {
  switch (p) {
    case sessions::SessionProgress::Phase::kTraining: return "training";
    case sessions::SessionProgress::Phase::kTrialStarted: return "trial";
    case sessions::SessionProgress::Phase::kTrialFinished: return "between trials";
  }
  return "";
}

}  // namespace

ConsoleSession::ConsoleSession(ConsoleSessionConfig config, OperatorActions& actions, OperatorActions& stop_actions,
                               DeviceHealth& device)
    : config_(std::move(config)),
      actions_(actions),
      stop_actions_(stop_actions),
      device_(device),
      live_(config_.live_rate_Hz, config_.live_window_s) {}

bool ConsoleSession::running() const {
  std::lock_guard lock(mutex_);
  return running_;
}

ConsoleSession::~ConsoleSession() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

void ConsoleSession::wait_until_ended() {
  if (thread_.joinable()) thread_.join();
}

void ConsoleSession::start(const std::string& participant, bool step) {
  std::lock_guard lock(mutex_);
  if (running_) throw ConsoleConflict("start: a session is running (" + participant_ + "); stop it first");
  device_.check_usable("start");
  if (thread_.joinable()) thread_.join();  // the previous, finished one
  device_.clear_alert();
  stop_.store(false);
  paused_.store(false);
  step_.store(step);
  allowed_trials_.store(0);
  started_trials_.store(0);
  pending_actions_.clear();
  progress_.reset();
  last_finished_.reset();
  result_.reset();
  error_.clear();
  live_.clear();
  running_ = true;
  session_id_.reset();
  waiting_for_next_ = false;
  rest_until_wall_s_.reset();
  rest_after_trial_s_.reset();
  participant_ = participant;
  thread_ = std::thread(&ConsoleSession::run, this, participant);
}

db::OperatorActionRow ConsoleSession::action_row(const char* action, std::string type, std::string detail) {
  std::unique_lock lock(mutex_);
  const auto no_session = [&] {
    return ConsoleConflict(std::string(action) + ": no session is running" +
                           (error_.empty() ? "" : " (the last one ended: " + error_ + ")") + "; nothing was done");
  };
  if (!running_) throw no_session();
  // Between "start" and the session's row (the device probed, the
  // database opened and recovered): a moment, normally.
  if (!opened_.wait_for(lock, std::chrono::seconds(5), [&] { return session_id_ || !running_; }))
    throw ConsoleConflict(std::string(action) + ": the session is still starting (opening the device and the "
                                                "database); nothing was done, try again");
  if (!running_) throw no_session();
  db::OperatorActionRow row;
  row.session_id = session_id_;
  if (progress_ && progress_->phase == sessions::SessionProgress::Phase::kTrialStarted) {
    row.trial_id = progress_->trial_id;
    row.t_s = live_.newest_t_s();
  }
  row.type = std::move(type);
  row.detail = std::move(detail);
  return row;
}

StopSnapshot ConsoleSession::stop() {
  // The runner polls this flag every 2 ms in a trial (after each drain in
  // training) and asks the loop to stop; the
  // loop commands zero force in the update that sees the request.
  stop_.store(true);
  std::lock_guard lock(mutex_);
  StopSnapshot s;
  s.unix_s = db::unix_now_s();
  s.session_running = running_;
  if (!running_) return s;
  s.session_id = session_id_;
  s.what = "session " + participant_;
  if (progress_ && progress_->phase == sessions::SessionProgress::Phase::kTrialStarted) {
    s.trial_id = progress_->trial_id;
    s.t_s = live_.newest_t_s();
    s.what += ", trial " + std::to_string(progress_->trial_number) + " (id " + std::to_string(progress_->trial_id) + ")";
  } else {
    s.what += progress_ && progress_->phase == sessions::SessionProgress::Phase::kTraining ? ", in training"
                                                                                          : ", between trials";
  }
  return s;
}

std::string ConsoleSession::record_stop(const StopSnapshot& snapshot, const std::string& detail) {
  db::OperatorActionRow row;
  row.session_id = snapshot.session_id;
  row.trial_id = snapshot.trial_id;
  row.t_s = snapshot.t_s;
  row.unix_s = snapshot.unix_s;
  row.type = "operator_stop";
  row.detail = detail;
  const auto set_last = [&](const char* recorded, const std::string& error) {
    std::lock_guard lock(mutex_);
    last_stop_ = {{"stopped", detail}, {"unix_s", snapshot.unix_s}, {"recorded", recorded}};
    if (!error.empty()) last_stop_["record_error"] = error;
  };
  set_last("pending", "");
  // Another connection may hold the lock (the sample writer's commit, a
  // control's, another program's): each try waits the connection's busy
  // timeout; a lock held past the writer's own patience is a failure.
  const auto first_try = std::chrono::steady_clock::now();
  for (;;) {
    try {
      stop_actions_.record(row);
      set_last("stored", "");
      return "";
    } catch (const db::DbError& e) {
      if (e.is_busy() && std::chrono::steady_clock::now() - first_try < db::kBusyPatience) continue;
      const std::string error = std::string("STOP acted, but could not be stored in the database: ") + e.what();
      set_last("failed", error);
      return error;
    } catch (const std::exception& e) {
      const std::string error = std::string("STOP acted, but could not be stored in the database: ") + e.what();
      set_last("failed", error);
      return error;
    }
  }
}

void ConsoleSession::next_trial() {
  actions_.record(action_row("next", "operator_next_trial", ""));
  allowed_trials_.fetch_add(1);
}

void ConsoleSession::set_paused(bool paused) {
  actions_.record(action_row(paused ? "pause" : "resume", paused ? "operator_pause" : "operator_resume", ""));
  {
    std::lock_guard lock(mutex_);
    rest_until_wall_s_.reset();
    rest_after_trial_s_.reset();
  }
  paused_.store(paused);
}

void ConsoleSession::rest(double seconds) {
  if (!std::isfinite(seconds) || seconds < 1.0 || seconds > 3600.0)
    throw std::invalid_argument("seconds: " + std::to_string(seconds) + ", must be 1..3600");
  char detail[32];
  std::snprintf(detail, sizeof detail, "%.0f s", seconds);
  actions_.record(action_row("rest", "operator_rest", detail));
  {
    std::lock_guard lock(mutex_);
    if (progress_ && progress_->phase != sessions::SessionProgress::Phase::kTrialFinished)
      rest_after_trial_s_ = seconds;  // the countdown starts when the trial (or training) ends
    else
      rest_until_wall_s_ = wall_now_s() + seconds;
  }
  paused_.store(true);
}

std::optional<double> ConsoleSession::rest_left_s() const {
  if (!rest_until_wall_s_ || !paused_.load()) return std::nullopt;
  return std::max(0.0, *rest_until_wall_s_ - wall_now_s());
}

void ConsoleSession::end_training() {
  actions_.record(action_row("end-training", "operator_end_training", ""));
  training_ends_.fetch_add(1);
}

void ConsoleSession::abort_trial(const std::string& reason, std::optional<std::int64_t> trial_id) {
  // Checked, stored and queued for the trial running now: between trials,
  // or once it has ended, the runner would otherwise abort the next one,
  // which the operator never saw (the page sends the trial it shows;
  // typing a reason can outlast a trial).
  db::OperatorActionRow row = action_row("abort", "operator_abort", reason);
  {
    std::lock_guard lock(mutex_);
    if (!running_ || !progress_ || progress_->phase != sessions::SessionProgress::Phase::kTrialStarted)
      throw ConsoleConflict("abort: no trial is running; nothing was aborted");
    const std::string running = "trial " + std::to_string(progress_->trial_number) + ", id " +
                                std::to_string(progress_->trial_id) + ", is running";
    if (trial_id == 0)  // the page showed none running when the operator clicked
      throw ConsoleConflict("abort: no trial was running when it was sent (" + running + "); nothing was aborted");
    if (trial_id && *trial_id != progress_->trial_id)
      throw ConsoleConflict("abort: trial id " + std::to_string(*trial_id) + " has ended (" + running +
                            "); nothing was aborted");
    row.trial_id = progress_->trial_id;
    row.t_s = live_.newest_t_s();
    pending_actions_.push_back({"operator_abort", reason, true, progress_->trial_id});
  }
  // Stored outside the lock (the pages' status waits on it): the runner
  // may take the abort first, but the answer waits for the record.
  try {
    actions_.record(row);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("abort: the trial is aborted, but the action could not be stored: ") +
                             e.what());
  }
}

void ConsoleSession::note(const std::string& text) { actions_.record(action_row("note", "operator_note", text)); }

bool ConsoleSession::hold_before_trial() {
  if (paused_.load()) {
    std::unique_lock lock(mutex_);
    // A rest asked for during training (no trial ended since) starts now.
    if (rest_after_trial_s_) {
      rest_until_wall_s_ = wall_now_s() + *rest_after_trial_s_;
      rest_after_trial_s_.reset();
    }
    const std::optional<double> left = rest_left_s();
    if (!left || *left > 0.0) return true;
    // The rest is over: the session goes on by itself (in step mode too,
    // as docs/console.md says: the next trial needs no "next"), stored as
    // a resume.
    rest_until_wall_s_.reset();
    paused_.store(false);
    if (step_.load() && allowed_trials_.load() <= started_trials_.load())
      allowed_trials_.store(started_trials_.load() + 1);
    db::OperatorActionRow row;
    row.session_id = session_id_;
    row.type = "operator_resume";
    row.detail = "rest over";
    lock.unlock();
    try {
      actions_.record(row);
    } catch (const std::exception& e) {
      std::lock_guard again(mutex_);
      error_ = std::string("the end of a rest could not be stored: ") + e.what();
    }
  }
  const bool wait = step_.load() && allowed_trials_.load() <= started_trials_.load();
  std::lock_guard lock(mutex_);
  waiting_for_next_ = wait;
  return wait;
}

void ConsoleSession::on_progress(const sessions::SessionProgress& p) {
  std::lock_guard lock(mutex_);
  waiting_for_next_ = false;
  if (p.phase == sessions::SessionProgress::Phase::kTrialStarted) {
    started_trials_.fetch_add(1);
    trial_started_wall_s_ = wall_now_s();
    live_.clear();
    loop_status_.reset();
  }
  if (p.phase == sessions::SessionProgress::Phase::kTrialFinished) {
    last_finished_ = p;
    if (rest_after_trial_s_) rest_until_wall_s_ = wall_now_s() + *rest_after_trial_s_;
    rest_after_trial_s_.reset();
  }
  progress_ = p;
}

void ConsoleSession::run(std::string participant) {
  sessions::SessionOptions options;
  options.participant = participant;
  options.device = config_.device;
  options.clock = config_.clock;
  options.rate_Hz = config_.rate_Hz;
  options.max_trial_s = config_.max_trial_s;
  options.training_trials = config_.training_trials;
  options.realtime = config_.realtime;
  options.population = config_.population;
  options.stop = &stop_;
  options.training_ends = &training_ends_;
  // At once, while the trial still runs (a device call that has not returned).
  options.on_alert = [this](const std::string& alert) { device_.alert(alert); };
  options.on_session_opened = [this](std::int64_t session_id) {
    {
      std::lock_guard lock(mutex_);
      session_id_ = session_id;
    }
    opened_.notify_all();
  };
  options.hold_before_trial = [this] { return hold_before_trial(); };
  options.take_operator_events = [this](std::vector<sessions::OperatorEvent>& out) {
    std::lock_guard lock(mutex_);
    out.insert(out.end(), pending_actions_.begin(), pending_actions_.end());
    pending_actions_.clear();
  };
  options.on_progress = [this](const sessions::SessionProgress& p) { on_progress(p); };
  options.on_loop_status = [this](const sessions::LoopStatus& status) {
    std::lock_guard lock(mutex_);
    loop_status_ = status;
  };
  // On the writer's thread: keep one point per 1/live_rate_Hz of loop time.
  options.writer.observe = [this](std::span<const LoopSample> batch) {
    std::lock_guard lock(mutex_);
    live_.add(batch);
  };
  std::optional<sessions::SessionResult> result;
  std::string error;
  try {
    result = sessions::run_session(config_.db, options);
  } catch (const sessions::DeviceHungError& e) {
    // The loop's thread is still in the device's code: no session or free
    // trial may open the device again in this process.
    error = e.what();
    device_.mark_hung(e.what());
  } catch (const std::exception& e) {
    error = e.what();
  }
  {
    std::lock_guard lock(mutex_);
    result_ = result;
    if (!error.empty()) error_ = error;
    running_ = false;
    waiting_for_next_ = false;
  }
  opened_.notify_all();
}

nlohmann::json ConsoleSession::operator_status() const {
  std::lock_guard lock(mutex_);
  nlohmann::json j = {{"running", running_}, {"participant", participant_}, {"paused", paused_.load()},
                      {"step", step_.load()}, {"error", error_}};
  if (session_id_) j["session_id"] = *session_id_;
  // Step mode, held before a trial: the page tells the operator to press Next.
  if (running_ && waiting_for_next_ && !paused_.load()) j["waiting_for_next"] = true;
  if (const auto left = rest_left_s(); left && running_) j["rest_left_s"] = std::ceil(*left);
  if (rest_after_trial_s_ && running_) j["rest_after_trial_s"] = *rest_after_trial_s_;
  if (progress_) {
    const auto& p = *progress_;
    j["phase"] = phase_name(p.phase);
    j["trial_number"] = p.trial_number;
    j["trial_id"] = p.trial_id;
    j["trial_count"] = p.trial_count;
    j["task"] = p.task;
    j["setting"] = p.setting;
    j["repetition"] = p.repetition;
    j["elapsed_s"] = p.elapsed_s;
    if (p.eta_s) j["time_left_s"] = *p.eta_s;
    if (p.phase == sessions::SessionProgress::Phase::kTrialStarted && running_)
      j["trial_elapsed_wall_s"] = wall_now_s() - trial_started_wall_s_;
  }
  if (loop_status_ && running_) {
    const sessions::LoopStatus& l = *loop_status_;
    j["loop"] = {{"elapsed_s", l.elapsed_s},
                 {"rate_Hz", l.timing.mean_period_s > 0 ? 1.0 / l.timing.mean_period_s : 0.0},
                 {"p99_period_ms", 1e3 * l.timing.p99_period_s},
                 {"max_period_ms", 1e3 * l.timing.max_period_s},
                 {"overruns", l.timing.overruns},
                 {"dropped_samples", l.dropped_samples},
                 // How far the writer's newest drained sample is behind the loop.
                 {"writer_lag_s", std::max(0.0, l.elapsed_s - live_.newest_t_s())}};
  }
  if (last_finished_) {
    j["last_trial_number"] = last_finished_->trial_number;
    j["last_trial_id"] = last_finished_->trial_id;
    j["last_status"] = db::to_string(last_finished_->status);
    j["last_abort_reason"] = last_finished_->abort_reason;
    // A fault of that trial (the loop's watchdog, a safety limit, the
    // device): the page shows it as the trial's fault, not as a pause.
    const std::string& r = last_finished_->abort_reason;
    if (r.starts_with("watchdog") || r.starts_with("safety limit") || r.starts_with("device") ||
        r.starts_with("rate_violation"))
      j["last_fault"] = r;
  }
  if (!last_stop_.is_null()) j["last_stop"] = last_stop_;
  j.update(device_.status());
  if (result_) {
    j["result"] = {{"trials_run", result_->trials_run},
                   {"trials_complete", result_->trials_complete},
                   {"trials_aborted", result_->trials_aborted},
                   {"trials_left", result_->trials_left},
                   {"stopped_by_operator", result_->stopped_by_operator},
                   {"device_fault", result_->device_fault_reason},
                   {"warnings", result_->condition_warnings}};
    // Nothing was to run: why, and no session was added.
    if (result_->nothing_to_run) j["result"]["nothing_to_run"] = *result_->nothing_to_run;
  }
  return j;
}

nlohmann::json ConsoleSession::participant_status() const {
  std::lock_guard lock(mutex_);
  // Built from scratch, field by field: nothing of the operator's view
  // (setting, parameters, abort reasons naming one) can leak by accident.
  nlohmann::json j = {{"cue", "ready"}};
  if (!running_) {
    // Ended: "done" only when no trial is left; a session stopped (or ended
    // by a fault) with trials left says so, and how many wait for later.
    if (result_ || !error_.empty()) {
      const int left = result_ ? result_->trials_left : -1;
      j["cue"] = left == 0 ? "done" : "stopped";
      if (left > 0) j["trials_left"] = left;
    }
    return j;
  }
  if (!progress_) return j;
  const auto& p = *progress_;
  j["trial_count"] = p.trial_count;
  j["task"] = p.task;
  using Phase = sessions::SessionProgress::Phase;
  if (p.phase == Phase::kTrialStarted) {
    j["cue"] = "go";
    j["trial_number"] = p.trial_number;  // only while it runs: between trials the last one's number is stale
  } else if (p.phase == Phase::kTraining) {
    j["cue"] = "practice";
  } else {
    j["cue"] = paused_.load() ? "rest" : "ready";
  }
  if (const auto left = rest_left_s(); left && j["cue"] == "rest") j["rest_left_s"] = std::ceil(*left);
  return j;
}

std::array<std::vector<LivePoint>, 2> ConsoleSession::live_since(double after_t_s) const {
  std::lock_guard lock(mutex_);
  return live_.since(after_t_s);
}

}  // namespace hapticlab::console
