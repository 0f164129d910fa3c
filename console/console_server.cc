#include "console/console_server.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <optional>
#include <set>
#include <stdexcept>

#include "console/access_tickets.h"
#include "console/console_results.h"
#include "console/console_tuning.h"
#include "console/control_fields.h"
#include "console/http/http_server.h"
#include "console/operator_actions.h"
#include "core/common/input_file.h"
#include "db/study_db.h"
#include "protocols/safety_json.h"
#include "sessions/study_progress.h"

namespace hapticlab::console {
namespace {

using http::Request;
using http::Response;
using http::Route;
using http::Runs;

constexpr std::size_t kMaxBodyBytes = 16 * 1024;  // notes and reasons are short
// STOP is answered within this of its head, stored or not (its record is
// written on a connection of its own, which another's lock can hold up).
constexpr auto kStopAnswerWithin = std::chrono::milliseconds(50);
// Connections and event streams per port: each port's own, so the
// participant's clients (who need no token) never take the operator's.
// The operator's page holds one stream per tab; the participant's screen one.
constexpr std::size_t kOperatorConnections = 384, kOperatorStreams = 64;
constexpr std::size_t kParticipantConnections = 128, kParticipantStreams = 16;
constexpr auto kLivePeriod = std::chrono::milliseconds(33);          // >= 30 Hz to the plots
constexpr auto kParticipantPeriod = std::chrono::milliseconds(100);  // the participant's cue
// Bounds on what the console reads into memory to serve.
constexpr std::size_t kMaxChartJsBytes = 16u << 20;

// The pages: scripts and styles only from files of the console's own
// origin (none inline), no plugin, no form, never framed by another page.
constexpr const char* kPageCsp =
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' data:; connect-src 'self'; "
    "frame-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'none'";
// The analysis' report (its own inline style and SVG figures, no script),
// shown in a frame of the Results page: that page may frame it, no other.
constexpr const char* kReportCsp =
    "default-src 'none'; img-src 'self' data:; style-src 'self' 'unsafe-inline'; frame-ancestors 'self'; "
    "base-uri 'none'; form-action 'none'; sandbox allow-same-origin";

// Compares without an early exit, so the time taken does not tell how much
// of a guessed token was right.
bool same_token(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

Response json_reply(const nlohmann::json& j, int status = 200) {
  Response r;
  r.status = status;
  r.body = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return r;
}

sessions::StudyProgress read_progress(const std::filesystem::path& db_path) {
  db::OpenOptions open;
  open.read_only = true;  // a session may be writing: change nothing
  open.integrity = db::OpenOptions::Integrity::kSkip;  // per request; `study check` does the full one
  db::StudyDb db(db_path, open);
  return sessions::study_progress(db);
}

struct StudySettings {
  std::vector<NamedSettings> settings;  // in order of first appearance in the schedules
  std::vector<std::string> tasks;
};

StudySettings read_study_settings(const std::filesystem::path& db_path, const sessions::StudyProgress& progress) {
  db::OpenOptions open;
  open.read_only = true;
  open.integrity = db::OpenOptions::Integrity::kSkip;
  db::StudyDb db(db_path, open);
  StudySettings out;
  std::set<std::int64_t> seen;
  for (const auto& p : progress.participants)
    for (const db::TrialRow& t : p.trials) {
      if (seen.insert(t.setting_id).second) out.settings.push_back(db.setting(t.setting_id));
      if (std::find(out.tasks.begin(), out.tasks.end(), t.task) == out.tasks.end()) out.tasks.push_back(t.task);
    }
  return out;
}

// A file of a folder the console writes (served_file.h), sent by the server
// from the file in pieces: a study's sample export is hundreds of megabytes.
Response download(const std::optional<std::filesystem::path>& path, const std::string& name) {
  if (!path) return Response::error(404, "no such file: " + name);
  const std::string file = path->filename().string();
  Response r;
  r.content_type = file.ends_with(".html")  ? "text/html; charset=utf-8"
                   : file.ends_with(".svg") ? "image/svg+xml"
                   : file.ends_with(".csv") ? "text/csv; charset=utf-8"
                   : file.ends_with(".gz")  ? "application/gzip"
                   : file.ends_with(".json") ? "application/json"
                                             : "text/plain; charset=utf-8";
  if (!file.ends_with(".html") && !file.ends_with(".svg"))
    r.headers.emplace_back("Content-Disposition", "attachment; filename=\"" + file + "\"");
  r.file = *path;
  return r;
}

// The state of a live stream's sender: what it has sent of the present
// trial (or free-trial repetition), so each event carries only new points.
struct LiveCursor {
  std::array<double, 2> last_t_s{-1.0, -1.0};
  int repetition = -1;
};

// One event of a live stream: the status and the points after `cursor`.
template <typename PointsOf>
nlohmann::json live_event(const nlohmann::json& status, const char* repetition_key, PointsOf points_of,
                          LiveCursor& cursor) {
  const int repetition = status.value(repetition_key, 0);
  if (repetition != cursor.repetition) cursor = LiveCursor{{-1.0, -1.0}, repetition};
  const auto points = points_of(std::min(cursor.last_t_s[0], cursor.last_t_s[1]));
  nlohmann::json j = {{"status", status}, {"instruments", nlohmann::json::array()}};
  for (std::size_t k = 0; k < 2; ++k) {
    nlohmann::json series = nlohmann::json::array();
    for (const LivePoint& p : points[k]) {
      if (p.t_s <= cursor.last_t_s[k]) continue;
      series.push_back({p.t_s, p.tip_force_N, p.displayed_force_N, p.insertion_m, p.pitch_rad, p.yaw_rad});
      cursor.last_t_s[k] = p.t_s;
    }
    j["instruments"].push_back(series);
  }
  return j;
}

std::string sse(const char* event, const nlohmann::json& data) {
  return std::string("event: ") + event + "\ndata: " +
         data.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n\n";
}

std::string url_host(const std::string& bind) {
  return bind.find(':') != std::string::npos ? "[" + bind + "]" : bind;
}

}  // namespace

ConsoleOutcome serve_console(const ConsoleConfig& config, const std::atomic<bool>& stop) {
  if (config.token.size() < 16) throw std::invalid_argument("console token: shorter than 16 characters");
  // Opened first: it brings an older file to the current schema, which the
  // read-only connections below need.
  OperatorActions actions(config.session.db);
  OperatorActions stop_actions(config.session.db);  // STOP's own connection: no control's wait is its
  DeviceHealth device_health;
  // The participants and settings of the study, read once: codes a request
  // may name, and (for the operator's page) the protocol summary.
  const sessions::StudyProgress at_start = read_progress(config.session.db);
  ConsoleSession session(config.session, actions, stop_actions, device_health);
  // Next to the database: STUDY.db -> STUDY-console-analysis/.
  ConsoleResults results(config.session.db,
                         config.session.db.parent_path() / (config.session.db.stem().string() + "-console-analysis"));
  // The study's settings and tasks, which a free trial on the Tuning page starts from.
  const StudySettings study_settings = read_study_settings(config.session.db, at_start);
  ConsoleTuningConfig tuning_config;
  tuning_config.device = config.session.device;
  tuning_config.realtime = config.session.realtime;
  tuning_config.clock = ClockKind::kWall;  // a free trial is felt (or watched) as it happens
  tuning_config.force_limits =
      protocols::safety_from_protocol_text(at_start.study.protocol_json, config.session.db.string());
  tuning_config.out_dir = config.session.db.parent_path() / (config.session.db.stem().string() + "-console-tuning");
  ConsoleTuning tuning(tuning_config, device_health);
  const std::string chart_js = std::filesystem::exists(config.chart_js)
                                   ? read_text_file(config.chart_js, kMaxChartJsBytes, "Chart.js file")
                                   : std::string();
  std::mutex device_mutex;  // starting a session or a free trial

  http::ServerConfig server_config;
  server_config.limits.max_body_bytes = kMaxBodyBytes;
  server_config.default_headers = {{"Cache-Control", "no-store"},
                                   {"X-Content-Type-Options", "nosniff"},
                                   {"X-Frame-Options", "DENY"},
                                   {"Content-Security-Policy", kPageCsp},
                                   {"Referrer-Policy", "no-referrer"}};
  http::Server server(server_config);
  int participant_port = 0;  // known once its site listens

  // --- who may: the token, in its header; for a GET a browser must name by
  // address (the stream, a frame, a download), a one-time ticket instead
  // (access_tickets.h). Checked on the loop as soon as the head is in,
  // before any body byte is read.
  AccessTickets tickets;
  const auto has_token = [&](const Request& req) {
    const std::string* token = req.header("x-hapticlab-token");
    return token != nullptr && same_token(*token, config.token);
  };
  const auto token_check = [&](Request& req) -> std::optional<Response> {
    if (!has_token(req))
      return Response::error(403, "missing or wrong X-HapticLab-Token header (the console printed the page's address "
                                  "with it, and it is in the token file); nothing was done");
    return std::nullopt;
  };
  const auto read_check = [&](Request& req) -> std::optional<Response> {
    if (has_token(req)) return std::nullopt;
    const std::string ticket = query_value(req.query, "ticket");
    if (!ticket.empty() && tickets.redeem(ticket, req.path)) return std::nullopt;
    return Response::error(403, "GET " + req.path.substr(0, 200) + ": " +
                                    (ticket.empty() ? std::string("missing or wrong X-HapticLab-Token header")
                                                    : std::string("the ticket is spent, expired or for another path")) +
                                    "; what the operator's port answers names settings and participants, so it needs "
                                    "the token (open the address the console printed, which ends in #token=...)");
  };

  // --- the operator's site: the page's shell and its scripts for anyone
  // with the right Host; everything that names a setting or a participant
  // only with the token
  std::vector<Route> op;
  const auto get = [&](const std::string& path, Runs runs, auto handle) {
    Route r;
    r.method = "GET";
    r.path = path;
    r.runs = runs;
    r.handle = handle;
    r.admit = read_check;
    return r;
  };
  for (std::size_t i = 0; i < kAssetCount; ++i) {
    const Asset& a = kAssets[i];
    if (std::string(a.site) != "operator") continue;
    op.push_back(get(a.path, Runs::kLoop, [a](const Request&) {
      return Response::text(200, a.body, std::string(a.content_type) + "; charset=utf-8");
    }));
    op.back().admit = nullptr;  // the same for everyone: it names nothing
  }
  op.push_back(get("/vendor/chart.js", Runs::kLoop, [&chart_js](const Request&) {
    if (chart_js.empty())
      return Response::text(404, "// chart.js not installed (Debian: apt install libjs-chart.js)", "text/javascript");
    Response r = Response::text(200, chart_js, "text/javascript; charset=utf-8");
    r.headers.emplace_back("Cache-Control", "max-age=3600");  // the same file for the console's lifetime
    return r;
  }));
  op.back().admit = nullptr;
  // --- read-only
  op.push_back(get("/api/study", Runs::kReader, [&](const Request&) {
    return json_reply(sessions::study_progress_json(read_progress(config.session.db)));
  }));
  op.push_back(get("/api/status", Runs::kLoop, [&](const Request&) {
    nlohmann::json j = session.operator_status();
    j["participant_port"] = participant_port;
    return json_reply(j);
  }));
  op.push_back(get("/api/tuning", Runs::kLoop, [&](const Request&) {
    nlohmann::json j = tuning.status();
    j["reference"] = ConsoleTuning::reference()["fields"];
    j["study_settings"] = nlohmann::json::array();
    for (const NamedSettings& n : study_settings.settings) j["study_settings"].push_back(n.name);
    j["tasks"] = study_settings.tasks;
    return json_reply(j);
  }));
  Route tuning_files = get("/tuning/", Runs::kReader, [&](const Request& req) {
    const std::string name = req.path.substr(std::string("/tuning/").size());
    return download(tuning.file(name), name);
  });
  tuning_files.prefix = true;
  op.push_back(tuning_files);
  op.push_back(get("/api/results", Runs::kReader, [&](const Request&) { return json_reply(results.status()); }));
  Route result_files = get("/results/", Runs::kReader, [&](const Request& req) {
    const std::string name = req.path.substr(std::string("/results/").size());
    std::optional<std::filesystem::path> path;
    try {
      path = results.file(name);
    } catch (const std::invalid_argument& e) {
      return Response::error(409, e.what());
    }
    Response r = download(path, name);
    r.headers.emplace_back("Content-Security-Policy", kReportCsp);
    r.headers.emplace_back("X-Frame-Options", "SAMEORIGIN");
    return r;
  });
  result_files.prefix = true;
  op.push_back(result_files);
  // One event stream for the operator's page, whatever it shows (a browser
  // allows six connections to a host: two streams a tab left the third
  // tab's STOP none): "live" (the session's status and plots) and, while a
  // free trial runs, "tuning" (its status and plots).
  Route stream;
  stream.method = "GET";
  stream.path = "/events/operator";
  stream.stream = "operator";
  stream.admit = read_check;
  op.push_back(stream);
  // A ticket for one of the GET routes above (answered on the loop: the
  // page's stream reconnects with a new one even while a control waits).
  {
    Route r;
    r.method = "POST";
    r.path = "/api/ticket";
    r.max_body_bytes = kMaxBodyBytes;
    r.admit = token_check;
    r.runs = Runs::kLoop;
    r.handle = [&](const Request& req) {
      try {
        const std::string path = text_field(parse_control_body(req.body), "path", 300);
        if (path != "/events/operator" && !path.starts_with("/results/") && !path.starts_with("/tuning/"))
          throw std::invalid_argument("path: '" + path + "' takes no ticket (only /events/operator, /results/NAME, "
                                      "/tuning/NAME: what a browser must open by address)");
        return json_reply({{"ticket", tickets.issue(path)}});
      } catch (const std::invalid_argument& e) {
        return Response::error(400, e.what());
      }
    };
    op.push_back(r);
  }

  // --- controls: token first (before any body byte is read), then the body
  const auto control_route = [&](const std::string& path, auto action, auto reply) {
    Route r;
    r.method = "POST";
    r.path = path;
    r.max_body_bytes = kMaxBodyBytes;
    r.admit = token_check;
    r.runs = Runs::kControl;
    r.handle = [action, reply](const Request& req) {
      try {
        action(parse_control_body(req.body));
        return json_reply(reply());
      } catch (const ConsoleConflict& e) {
        return Response::error(409, e.what());
      } catch (const std::invalid_argument& e) {
        return Response::error(400, e.what());
      } catch (const std::exception& e) {
        return Response::error(500, e.what());
      }
    };
    return r;
  };
  const auto control = [&](const std::string& path, auto action) {
    op.push_back(control_route(path, action, [&] { return session.operator_status(); }));
  };
  const auto tuning_control = [&](const std::string& path, auto action) {
    op.push_back(control_route(path, action, [&] { return tuning.status(); }));
  };
  const auto known_participant = [&](const std::string& code) {
    for (const auto& p : at_start.participants)
      if (p.code == code) return true;
    return false;
  };
  control("/api/session/start", [&](const nlohmann::json& body) {
    const std::string code = text_field(body, "participant", 64);
    const bool step = bool_field(body, "step", false);
    if (!known_participant(code)) {
      std::string codes;
      for (const auto& p : at_start.participants) codes += (codes.empty() ? "" : ", ") + p.code;
      throw std::invalid_argument("participant: '" + code + "' is not one of the study's (" + codes + ")");
    }
    // One loop drives the device: a free trial and a session never run at once.
    std::lock_guard lock(device_mutex);
    if (tuning.running()) throw ConsoleConflict("start: a free trial runs on the Tuning page; stop it first");
    session.start(code, step);
  });
  // STOP stops whatever drives the device, at once: on the server's loop
  // thread as soon as its head is in and the token checked, before its
  // body is read and before anything waits. Then, on the urgent thread
  // (never behind a control) and its own database connection, it is
  // stored, and answered; if storing takes longer than kStopAnswerWithin
  // (another connection holds the database's lock), the loop answers
  // without waiting, saying the record is pending, and the status says
  // when it is stored.
  const auto stopped_text = [](const nlohmann::json& noted) {
    std::string stopped = noted["what"].get<std::string>();
    if (noted["free_trial"].get<bool>()) stopped += (stopped.empty() ? "" : "; ") + std::string("the free trial");
    if (stopped.empty()) stopped = "nothing was running";
    return stopped;
  };
  {
    Route r;
    r.method = "POST";
    r.path = "/api/session/stop";
    r.max_body_bytes = kMaxBodyBytes;
    r.admit = [&](Request& req) -> std::optional<Response> {
      if (auto refusal = token_check(req)) return refusal;
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
    };
    r.runs = Runs::kUrgent;
    r.handle = [&, stopped_text](const Request& req) {
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
    };
    r.answer_within = kStopAnswerWithin;
    r.answer_late = [&, stopped_text](const Request& req) {
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
    op.push_back(r);
  }
  tuning_control("/api/tuning/start", [&](const nlohmann::json& body) {
    const std::string task = text_field(body, "task", 64);
    const std::string from = text_field(body, "from", 200);
    const NamedSettings* start = nullptr;
    std::string names;
    for (const NamedSettings& n : study_settings.settings) {
      if (n.name == from) start = &n;
      names += (names.empty() ? "" : ", ") + ("'" + n.name + "'");
    }
    if (start == nullptr) throw std::invalid_argument("from: '" + from + "' is not a setting of the study (" + names + ")");
    std::lock_guard lock(device_mutex);
    if (session.running()) throw ConsoleConflict("a session is running; the Tuning page is for pilot work outside one");
    tuning.start(task, *start);
  });
  tuning_control("/api/tuning/stop", [&](const nlohmann::json&) { tuning.stop(); });
  tuning_control("/api/tuning/set", [&](const nlohmann::json& body) {
    if (!body.contains("value")) throw std::invalid_argument("value: missing (a number, or true/false for \"enabled\")");
    tuning.set(text_field(body, "field", 200), body["value"]);
  });
  tuning_control("/api/tuning/save", [&](const nlohmann::json& body) { (void)tuning.save(text_field(body, "name", 64)); });
  control("/api/session/next", [&](const nlohmann::json&) { session.next_trial(); });
  control("/api/session/pause", [&](const nlohmann::json& body) { session.set_paused(bool_field(body, "paused", true)); });
  control("/api/session/rest", [&](const nlohmann::json& body) {
    session.rest(number_field(body, "seconds", 1.0, 3600.0));
  });
  control("/api/session/end-training", [&](const nlohmann::json&) { session.end_training(); });
  control("/api/session/abort", [&](const nlohmann::json& body) {
    // The trial the operator saw running (0: none); absent: the one running now.
    std::optional<std::int64_t> trial_id;
    if (body.contains("trial_id")) trial_id = integer_field(body, "trial_id", 0, INT64_MAX, 0);
    session.abort_trial(text_field(body, "reason", 500), trial_id);
  });
  control("/api/results/export", [&](const nlohmann::json& body) {
    const std::string participant = optional_text_field(body, "participant", 64, "", true);
    if (!participant.empty() && !known_participant(participant))
      throw std::invalid_argument("participant: '" + participant + "' is not one of the study's");
    const std::int64_t every = integer_field(body, "every", 1, 1000000, 1);
    results.start_export(participant, static_cast<std::uint64_t>(every), bool_field(body, "gzip", true));
  });
  control("/api/results/analyze", [&](const nlohmann::json& body) { results.start(bool_field(body, "plots", true)); });
  control("/api/session/note", [&](const nlohmann::json& body) { session.note(text_field(body, "text", 2000)); });

  // --- the participant's site: its page and its stream, nothing else
  std::vector<Route> pp;
  for (std::size_t i = 0; i < kAssetCount; ++i) {
    const Asset& a = kAssets[i];
    if (std::string(a.site) != "participant") continue;
    pp.push_back(get(a.path, Runs::kLoop, [a](const Request&) {
      return Response::text(200, a.body, std::string(a.content_type) + "; charset=utf-8");
    }));
    pp.back().admit = nullptr;  // the participant's screen: it names no setting
  }
  Route participant_stream;
  participant_stream.method = "GET";
  participant_stream.path = "/events/participant";
  participant_stream.stream = "participant";
  pp.push_back(participant_stream);

  // --- the streams, fanned out from the loop thread
  LiveCursor session_cursor, tuning_cursor;
  const auto session_points = [&](double after_t_s) { return session.live_since(after_t_s); };
  const auto tuning_points = [&](double after_t_s) { return tuning.live_since(after_t_s); };
  const auto tuning_view = [&] {
    nlohmann::json j = tuning.status();
    j.erase("log");  // the page polls /api/tuning for it
    j.erase("settings");
    return j;
  };
  server.add_channel("operator", [&] {
    // A new page: everything of the window so far, from cursors of its own.
    LiveCursor fresh_session, fresh_tuning;
    return sse("live", live_event(session.operator_status(), "trial_number", session_points, fresh_session)) +
           sse("tuning", live_event(tuning_view(), "free_trial", tuning_points, fresh_tuning));
  });
  server.add_channel("participant", [&] { return sse("participant", session.participant_status()); });
  bool tuning_was_running = false;
  server.every(kLivePeriod, [&] {
    if (!server.has_subscribers("operator")) return;
    std::string events = sse("live", live_event(session.operator_status(), "trial_number", session_points, session_cursor));
    const bool tuning_running = tuning.running();
    if (tuning_running || tuning_was_running)
      events += sse("tuning", live_event(tuning_view(), "free_trial", tuning_points, tuning_cursor));
    tuning_was_running = tuning_running;
    server.publish("operator", events);
  });
  server.every(kParticipantPeriod, [&] {
    if (server.has_subscribers("participant"))
      server.publish("participant", sse("participant", session.participant_status()));
  });

  const int port = server.add_site(
      {"operator", config.bind_address, config.port, std::move(op), kOperatorConnections, kOperatorStreams});
  participant_port = server.add_site({"participant", config.bind_address, config.participant_port, std::move(pp),
                                      kParticipantConnections, kParticipantStreams});
  const std::string host = url_host(config.bind_address);
  std::printf("console: http://%s:%d/#token=%s  (the operator's page; the token stays in the page)\n", host.c_str(),
              port, config.token.c_str());
  std::printf("participant screen: http://%s:%d/participant  (open it on the participant's display)\n", host.c_str(),
              participant_port);
  std::fflush(stdout);
  server.run(stop);
  session.stop();
  tuning.stop();
  ConsoleOutcome outcome;
  outcome.device_hung = device_health.hung();
  return outcome;
}

}  // namespace hapticlab::console
