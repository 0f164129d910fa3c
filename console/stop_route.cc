#include "console/stop_route.h"

#include <cstdint>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "console/json_reply.h"

namespace hapticlab::console {
namespace {

using http::Request;
using http::Response;

// What STOP stopped, in words, from what its admission noted.
std::string stopped_text(const nlohmann::json& noted) {
  std::string stopped = noted["what"].get<std::string>();
  if (noted["free_trial"].get<bool>()) stopped += (stopped.empty() ? "" : "; ") + std::string("the free trial");
  if (stopped.empty()) stopped = "nothing was running";
  return stopped;
}

// On the loop, as STOP's head is in: stops, and notes what it stopped.
std::optional<Response> stop_at_once(ConsoleSession& session, ConsoleTuning& tuning, Request& req) {
  const bool free_trial = tuning.running();
  const StopSnapshot s = session.stop();
  tuning.stop();
  nlohmann::json noted = {{"what", s.what}, {"free_trial", free_trial}, {"session_running", s.session_running},
                          {"unix_s", s.unix_s}};
  if (s.session_id) noted["session_id"] = *s.session_id;
  if (s.trial_id) noted["trial_id"] = *s.trial_id;
  if (s.t_s) noted["t_s"] = *s.t_s;
  req.admitted = noted.dump();
  return std::nullopt;
}

// On the urgent thread: stores the STOP noted, and answers.
Response record_stop(ConsoleSession& session, const Request& req) {
  const nlohmann::json noted = nlohmann::json::parse(req.admitted);
  StopSnapshot s;
  s.session_running = noted["session_running"];
  s.unix_s = noted["unix_s"].get<double>();
  if (noted.contains("session_id")) s.session_id = noted["session_id"].get<std::int64_t>();
  if (noted.contains("trial_id")) s.trial_id = noted["trial_id"].get<std::int64_t>();
  if (noted.contains("t_s")) s.t_s = noted["t_s"].get<double>();
  const std::string stopped = stopped_text(noted);
  // Stopped all the same when it cannot be stored: the answer says so.
  const std::string error = session.record_stop(s, stopped);
  nlohmann::json j = session.operator_status();
  j["stopped"] = stopped;
  j["recorded"] = error.empty();
  if (!error.empty()) j["record_error"] = error;
  return json_reply(j);
}

}  // namespace

// STOP stops whatever drives the device, at once: on the server's loop
// thread as soon as its head is in and the token checked, before its
// body is read and before anything waits. Then, on the urgent thread
// (never behind a control) and its own database connection, it is
// stored, and answered; if storing takes longer than kStopAnswerWithin
// (another connection holds the database's lock), the loop answers
// without waiting, saying the record is pending, and the status says
// when it is stored.
http::Route stop_route(ConsoleSession& session, ConsoleTuning& tuning,
                       std::function<std::optional<Response>(Request&)> token_check, std::size_t max_body_bytes) {
  http::Route r;
  r.method = "POST";
  r.path = "/api/session/stop";
  r.max_body_bytes = max_body_bytes;
  r.admit = [&session, &tuning, token_check = std::move(token_check)](Request& req) -> std::optional<Response> {
    if (auto refusal = token_check(req)) return refusal;
    return stop_at_once(session, tuning, req);
  };
  r.runs = http::Runs::kUrgent;
  r.handle = [&session](const Request& req) { return record_stop(session, req); };
  r.answer_within = kStopAnswerWithin;
  r.answer_late = [&session](const Request& req) {
    const nlohmann::json noted = nlohmann::json::parse(req.admitted);
    nlohmann::json j = session.operator_status();
    j["stopped"] = stopped_text(noted);
    j["recorded"] = false;
    j["record_pending"] = true;
    j["record_error"] = "STOP acted (the loop stops at zero force), but its record is not stored yet: the study "
                        "database is busy (another connection holds its lock); it is stored as soon as the lock is "
                        "free, and the status' last_stop says when";
    return json_reply(j);
  };
  return r;
}

}  // namespace hapticlab::console
