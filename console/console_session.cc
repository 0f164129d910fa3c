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

ConsoleSession::ConsoleSession(ConsoleSessionConfig config)
    : config_(std::move(config)), live_(config_.live_rate_Hz, config_.live_window_s) {}

bool ConsoleSession::running() const {
  std::lock_guard lock(mutex_);
  return running_;
}

ConsoleSession::~ConsoleSession() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

void ConsoleSession::start(const std::string& participant, bool step) {
  std::lock_guard lock(mutex_);
  if (running_) throw std::invalid_argument("a session is running (" + participant_ + "); stop it first");
  if (thread_.joinable()) thread_.join();  // the previous, finished one
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
  rest_until_wall_s_.reset();
  rest_after_trial_s_.reset();
  participant_ = participant;
  thread_ = std::thread(&ConsoleSession::run, this, participant);
}

void ConsoleSession::log_action(std::string type, std::string detail, bool abort) {
  std::lock_guard lock(mutex_);
  pending_actions_.push_back({std::move(type), std::move(detail), abort});
}

void ConsoleSession::stop() {
  // The runner polls this flag every 2 ms and asks the loop to stop; the
  // loop commands zero force in the update that sees the request.
  stop_.store(true);
}

void ConsoleSession::next_trial() {
  allowed_trials_.fetch_add(1);
  log_action("operator_next_trial", "");
}

void ConsoleSession::set_paused(bool paused) {
  {
    std::lock_guard lock(mutex_);
    rest_until_wall_s_.reset();
    rest_after_trial_s_.reset();
  }
  paused_.store(paused);
  log_action(paused ? "operator_pause" : "operator_resume", "");
}

void ConsoleSession::rest(double seconds) {
  if (!std::isfinite(seconds) || seconds < 1.0 || seconds > 3600.0)
    throw std::invalid_argument("rest: seconds is " + std::to_string(seconds) + ", must be 1..3600");
  {
    std::lock_guard lock(mutex_);
    if (!running_) throw std::invalid_argument("rest: no session is running");
    if (progress_ && progress_->phase != sessions::SessionProgress::Phase::kTrialFinished)
      rest_after_trial_s_ = seconds;  // the countdown starts when the trial (or training) ends
    else
      rest_until_wall_s_ = wall_now_s() + seconds;
  }
  paused_.store(true);
  char detail[32];
  std::snprintf(detail, sizeof detail, "%.0f s", seconds);
  log_action("operator_rest", detail);
}

std::optional<double> ConsoleSession::rest_left_s() const {
  if (!rest_until_wall_s_ || !paused_.load()) return std::nullopt;
  return std::max(0.0, *rest_until_wall_s_ - wall_now_s());
}

void ConsoleSession::end_training() {
  training_ends_.fetch_add(1);
  log_action("operator_end_training", "");
}

void ConsoleSession::abort_trial(const std::string& reason, std::optional<std::int64_t> trial_id) {
  // Checked and queued under one lock, for the trial running now: between
  // trials, or once it has ended, the runner would otherwise abort the next
  // one, which the operator never saw (the page sends the trial it shows;
  // typing a reason can outlast a trial).
  std::lock_guard lock(mutex_);
  if (!running_ || !progress_ || progress_->phase != sessions::SessionProgress::Phase::kTrialStarted)
    throw std::invalid_argument("abort: no trial is running");
  const std::string running = "trial " + std::to_string(progress_->trial_number) + ", id " +
                              std::to_string(progress_->trial_id) + ", is running";
  if (trial_id == 0)  // the page showed none running when the operator clicked
    throw std::invalid_argument("abort: no trial was running when it was sent (" + running + "); nothing was aborted");
  if (trial_id && *trial_id != progress_->trial_id)
    throw std::invalid_argument("abort: trial id " + std::to_string(*trial_id) + " has ended (" + running +
                                "); nothing was aborted");
  pending_actions_.push_back({"operator_abort", reason, true, progress_->trial_id});
}

void ConsoleSession::note(const std::string& text) {
  {
    // A note is an event of a trial: the running one, or the next.
    std::lock_guard lock(mutex_);
    if (!running_) throw std::invalid_argument("note: no session is running (a note is logged with a trial)");
  }
  log_action("operator_note", text);
}

void ConsoleSession::run(std::string participant) {
  sessions::SessionOptions options;
  options.participant = participant;
  options.device = config_.device;
  options.clock = config_.clock;
  options.max_trial_s = config_.max_trial_s;
  options.training_trials = config_.training_trials;
  options.realtime = config_.realtime;
  options.stop = &stop_;
  options.training_ends = &training_ends_;
  options.hold_before_trial = [this] {
    if (paused_.load()) {
      std::lock_guard lock(mutex_);
      // A rest asked for during training (no trial ended since) starts now.
      if (rest_after_trial_s_) {
        rest_until_wall_s_ = wall_now_s() + *rest_after_trial_s_;
        rest_after_trial_s_.reset();
      }
      const std::optional<double> left = rest_left_s();
      if (!left || *left > 0.0) return true;
      // The rest is over: the session goes on by itself, logged as a resume.
      rest_until_wall_s_.reset();
      paused_.store(false);
      pending_actions_.push_back({"operator_resume", "rest over", false});
    }
    if (step_.load() && allowed_trials_.load() <= started_trials_.load()) return true;
    return false;
  };
  options.take_operator_events = [this](std::vector<sessions::OperatorEvent>& out) {
    std::lock_guard lock(mutex_);
    out.insert(out.end(), pending_actions_.begin(), pending_actions_.end());
    pending_actions_.clear();
  };
  options.on_progress = [this](const sessions::SessionProgress& p) {
    std::lock_guard lock(mutex_);
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
  };
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
  } catch (const std::exception& e) {
    error = e.what();
  }
  std::lock_guard lock(mutex_);
  result_ = result;
  error_ = error;
  running_ = false;
}

nlohmann::json ConsoleSession::operator_status() const {
  std::lock_guard lock(mutex_);
  nlohmann::json j = {{"running", running_}, {"participant", participant_}, {"paused", paused_.load()},
                      {"step", step_.load()}, {"error", error_}};
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
    j["last_status"] = db::to_string(last_finished_->status);
    j["last_abort_reason"] = last_finished_->abort_reason;
  }
  if (result_) {
    j["result"] = {{"trials_run", result_->trials_run},
                   {"trials_complete", result_->trials_complete},
                   {"trials_aborted", result_->trials_aborted},
                   {"trials_left", result_->trials_left},
                   {"stopped_by_operator", result_->stopped_by_operator},
                   {"device_fault", result_->device_fault_reason}};
  }
  return j;
}

nlohmann::json ConsoleSession::participant_status() const {
  std::lock_guard lock(mutex_);
  // Built from scratch, field by field: nothing of the operator's view
  // (setting, parameters, abort reasons naming one) can leak by accident.
  nlohmann::json j = {{"cue", "ready"}};
  if (!progress_) return j;
  const auto& p = *progress_;
  j["trial_number"] = p.trial_number;
  j["trial_count"] = p.trial_count;
  j["task"] = p.task;
  using Phase = sessions::SessionProgress::Phase;
  if (!running_) j["cue"] = "done";
  else if (p.phase == Phase::kTrialStarted) j["cue"] = "go";
  else if (p.phase == Phase::kTraining) j["cue"] = "practice";
  else j["cue"] = paused_.load() ? "rest" : "ready";
  if (const auto left = rest_left_s(); left && running_ && j["cue"] == "rest") j["rest_left_s"] = std::ceil(*left);
  return j;
}

std::array<std::vector<LivePoint>, 2> ConsoleSession::live_since(double after_t_s) const {
  std::lock_guard lock(mutex_);
  return live_.since(after_t_s);
}

}  // namespace hapticlab::console
