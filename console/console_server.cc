#include "console/console_server.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <utility>

#include "console/access_tickets.h"
#include "console/console_results.h"
#include "console/console_tuning.h"
#include "console/control_fields.h"
#include "console/http/http_server.h"
#include "console/json_reply.h"
#include "console/live_events.h"
#include "console/operator_actions.h"
#include "console/stop_route.h"
#include "core/common/input_file.h"
#include "db/study_db.h"
#include "protocols/loop_protections.h"
#include "protocols/protocol_json.h"
#include "sessions/study_progress.h"

namespace hapticlab::console {
namespace {

using http::Request;
using http::Response;
using http::Route;
using http::Runs;

constexpr std::size_t kMaxBodyBytes = 16 * 1024;  // notes and reasons are short
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

std::string url_host(const std::string& bind) {
  return bind.find(':') != std::string::npos ? "[" + bind + "]" : bind;
}

// A control: token first (before any body byte is read), then the body,
// on the control thread; `reply()` the status it answers with.
// `fields`: the keys its body may hold; any other is refused before the
// action (a misspelt one would be ignored).
template <typename Action, typename Reply>
Route control_route(const std::string& path, std::vector<std::string> fields,
                    std::function<std::optional<Response>(Request&)> admit, Action action, Reply reply) {
  Route r;
  r.method = "POST";
  r.path = path;
  r.max_body_bytes = kMaxBodyBytes;
  r.admit = std::move(admit);
  r.runs = Runs::kControl;
  r.handle = [path, fields = std::move(fields), action, reply](const Request& req) {
    try {
      const nlohmann::json body = parse_control_body(req.body);
      check_field_names(body, "POST " + path, fields);
      action(body);
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
}

// The console's state, made once at start, and the routes of its two sites
// that serve from it. The server is made after it and goes first (its
// workers' routes use all of it).
class Console {
 public:
  explicit Console(const ConsoleConfig& config)
      : config_(config),
        // Opened first: it brings an older file to the current schema, which
        // the read-only connections below need.
        actions_(config.session.db),
        stop_actions_(config.session.db),  // STOP's own connection: no control's wait is its
        // The participants and settings of the study, read once: codes a
        // request may name, and (for the operator's page) the protocol summary.
        at_start_(read_progress(config.session.db)),
        session_(config.session, actions_, stop_actions_, device_health_),
        // Next to the database: STUDY.db -> STUDY-console-analysis/.
        results_(config.session.db,
                 config.session.db.parent_path() / (config.session.db.stem().string() + "-console-analysis")),
        // The study's settings and tasks, which a free trial on the Tuning page starts from.
        study_settings_(read_study_settings(config.session.db, at_start_)),
        tuning_(tuning_config(config, at_start_), device_health_),
        chart_js_(std::filesystem::exists(config.chart_js)
                      ? read_text_file(config.chart_js, kMaxChartJsBytes, "Chart.js file")
                      : std::string()) {}

  // --- the operator's site: the page's shell and its scripts for anyone
  // with the right Host; everything that names a setting or a participant
  // only with the token
  std::vector<Route> operator_routes() {
    std::vector<Route> op;
    add_page_routes(op);
    add_read_routes(op);
    op.push_back(ticket_route());
    add_session_controls(op);
    op.push_back(stop_route(session_, tuning_, token_admit(), kMaxBodyBytes));
    add_tuning_controls(op);
    add_other_controls(op);
    return op;
  }

  // --- the participant's site: its page and its stream, nothing else
  std::vector<Route> participant_routes() {
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
    return pp;
  }

  // --- the streams, fanned out from the loop thread
  void add_streams(http::Server& server) {
    const auto session_points = [this](double after_t_s) { return session_.live_since(after_t_s); };
    const auto tuning_points = [this](double after_t_s) { return tuning_.live_since(after_t_s); };
    server.add_channel("operator", [this, session_points, tuning_points] {
      // A new page: everything of the window so far, from cursors of its own.
      LiveCursor fresh_session, fresh_tuning;
      return sse("live", live_event(session_.operator_status(), "trial_number", session_points, fresh_session)) +
             sse("tuning", live_event(tuning_view(), "free_trial", tuning_points, fresh_tuning));
    });
    server.add_channel("participant", [this] { return sse("participant", session_.participant_status()); });
    server.every(kLivePeriod, [this, &server, session_points, tuning_points] {
      if (!server.has_subscribers("operator")) return;
      std::string events =
          sse("live", live_event(session_.operator_status(), "trial_number", session_points, session_cursor_));
      const bool tuning_running = tuning_.running();
      if (tuning_running || tuning_was_running_)
        events += sse("tuning", live_event(tuning_view(), "free_trial", tuning_points, tuning_cursor_));
      tuning_was_running_ = tuning_running;
      server.publish("operator", events);
    });
    server.every(kParticipantPeriod, [this, &server] {
      if (server.has_subscribers("participant"))
        server.publish("participant", sse("participant", session_.participant_status()));
    });
  }

  // Known once its site listens.
  void set_participant_port(int port) { participant_port_ = port; }

  // Whatever drives the device stops (zero force); the outcome.
  ConsoleOutcome shut_down() {
    session_.stop();
    tuning_.stop();
    // A device call that hangs is marked so only as the session or free
    // trial gives up on it: read after their threads end, or a Ctrl-C in
    // the grace period would exit 0 after a hang.
    session_.wait_until_ended();
    tuning_.wait_until_ended();
    ConsoleOutcome outcome;
    outcome.device_hung = device_health_.hung();
    return outcome;
  }

 private:
  static ConsoleTuningConfig tuning_config(const ConsoleConfig& config, const sessions::StudyProgress& at_start) {
    ConsoleTuningConfig c;
    c.device = config.session.device;
    c.realtime = config.session.realtime;
    c.clock = ClockKind::kWall;  // a free trial is felt (or watched) as it happens
    c.population = config.session.population;
    c.rate_Hz = config.session.rate_Hz;
    // The rig of the study's sessions: the protocol's force limits and rate
    // tolerance (a free trial held to the default 10 % stopped as
    // rate_violation where the study's sessions went on).
    c.protections =
        protocols::loop_protections_from_protocol_text(at_start.study.protocol_json, config.session.db.string());
    c.out_dir = config.session.db.parent_path() / (config.session.db.stem().string() + "-console-tuning");
    return c;
  }

  // --- who may: the token, in its header; for a GET a browser must name by
  // address (the stream, a frame, a download), a one-time ticket instead
  // (access_tickets.h). Checked on the loop as soon as the head is in,
  // before any body byte is read.
  bool has_token(const Request& req) const {
    const std::string* token = req.header("x-hapticlab-token");
    return token != nullptr && same_token(*token, config_.token);
  }
  std::optional<Response> token_check(Request& req) const {
    if (!has_token(req))
      return Response::error(403, "missing or wrong X-HapticLab-Token header (the console printed the page's address "
                                  "with it, and it is in the token file); nothing was done");
    return std::nullopt;
  }
  std::optional<Response> read_check(Request& req) {
    if (has_token(req)) return std::nullopt;
    const std::string ticket = query_value(req.query, "ticket");
    if (!ticket.empty() && tickets_.redeem(ticket, req.path)) return std::nullopt;
    return Response::error(403, "GET " + req.path.substr(0, 200) + ": " +
                                    (ticket.empty() ? std::string("missing or wrong X-HapticLab-Token header")
                                                    : std::string("the ticket is spent, expired or for another path")) +
                                    "; what the operator's port answers names settings and participants, so it needs "
                                    "the token (open the address the console printed, which ends in #token=...)");
  }
  std::function<std::optional<Response>(Request&)> token_admit() {
    return [this](Request& req) { return token_check(req); };
  }

  Route get(const std::string& path, Runs runs, std::function<Response(const Request&)> handle) {
    Route r;
    r.method = "GET";
    r.path = path;
    r.runs = runs;
    r.handle = std::move(handle);
    r.admit = [this](Request& req) { return read_check(req); };
    return r;
  }

  // The operator's page and its scripts.
  void add_page_routes(std::vector<Route>& op) {
    for (std::size_t i = 0; i < kAssetCount; ++i) {
      const Asset& a = kAssets[i];
      if (std::string(a.site) != "operator") continue;
      op.push_back(get(a.path, Runs::kLoop, [a](const Request&) {
        return Response::text(200, a.body, std::string(a.content_type) + "; charset=utf-8");
      }));
      op.back().admit = nullptr;  // the same for everyone: it names nothing
    }
    op.push_back(get("/vendor/chart.js", Runs::kLoop, [this](const Request&) {
      if (chart_js_.empty())
        return Response::text(404, "// chart.js not installed (Debian: apt install libjs-chart.js)", "text/javascript");
      Response r = Response::text(200, chart_js_, "text/javascript; charset=utf-8");
      r.headers.emplace_back("Cache-Control", "max-age=3600");  // the same file for the console's lifetime
      return r;
    }));
    op.back().admit = nullptr;
  }

  // --- read-only
  void add_read_routes(std::vector<Route>& op) {
    op.push_back(get("/api/study", Runs::kReader, [this](const Request&) {
      return json_reply(sessions::study_progress_json(read_progress(config_.session.db)));
    }));
    op.push_back(get("/api/status", Runs::kLoop, [this](const Request&) {
      nlohmann::json j = session_.operator_status();
      j["participant_port"] = participant_port_;
      return json_reply(j);
    }));
    op.push_back(get("/api/tuning", Runs::kLoop, [this](const Request&) {
      nlohmann::json j = tuning_.status();
      j["reference"] = ConsoleTuning::reference()["fields"];
      j["study_settings"] = nlohmann::json::array();
      for (const NamedSettings& n : study_settings_.settings) j["study_settings"].push_back(n.name);
      j["tasks"] = study_settings_.tasks;
      return json_reply(j);
    }));
    Route tuning_files = get("/tuning/", Runs::kReader, [this](const Request& req) {
      const std::string name = req.path.substr(std::string("/tuning/").size());
      return download(tuning_.file(name), name);
    });
    tuning_files.prefix = true;
    op.push_back(tuning_files);
    op.push_back(get("/api/results", Runs::kReader, [this](const Request&) { return json_reply(results_.status()); }));
    Route result_files = get("/results/", Runs::kReader, [this](const Request& req) {
      const std::string name = req.path.substr(std::string("/results/").size());
      std::optional<std::filesystem::path> path;
      try {
        path = results_.file(name);
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
    stream.admit = [this](Request& req) { return read_check(req); };
    op.push_back(stream);
  }

  // A ticket for one of the GET routes above (answered on the loop: the
  // page's stream reconnects with a new one even while a control waits).
  Route ticket_route() {
    Route r;
    r.method = "POST";
    r.path = "/api/ticket";
    r.max_body_bytes = kMaxBodyBytes;
    r.admit = token_admit();
    r.runs = Runs::kLoop;
    r.handle = [this](const Request& req) {
      try {
        const std::string path = text_field(parse_control_body(req.body), "path", 300);
        if (path != "/events/operator" && !path.starts_with("/results/") && !path.starts_with("/tuning/"))
          throw std::invalid_argument("path: '" + path + "' takes no ticket (only /events/operator, /results/NAME, "
                                      "/tuning/NAME: what a browser must open by address)");
        return json_reply({{"ticket", tickets_.issue(path)}});
      } catch (const std::invalid_argument& e) {
        return Response::error(400, e.what());
      }
    };
    return r;
  }

  // --- controls
  template <typename Action>
  void control(std::vector<Route>& op, const std::string& path, std::vector<std::string> fields, Action action) {
    op.push_back(
        control_route(path, std::move(fields), token_admit(), action, [this] { return session_.operator_status(); }));
  }
  template <typename Action>
  void tuning_control(std::vector<Route>& op, const std::string& path, std::vector<std::string> fields,
                      Action action) {
    op.push_back(control_route(path, std::move(fields), token_admit(), action, [this] { return tuning_.status(); }));
  }
  bool known_participant(const std::string& code) const {
    for (const auto& p : at_start_.participants)
      if (p.code == code) return true;
    return false;
  }

  void add_session_controls(std::vector<Route>& op) {
    control(op, "/api/session/start", {"participant", "step"}, [this](const nlohmann::json& body) {
      const std::string code = text_field(body, "participant", 64);
      const bool step = bool_field(body, "step", false);
      if (!known_participant(code)) {
        std::string codes;
        for (const auto& p : at_start_.participants) codes += (codes.empty() ? "" : ", ") + p.code;
        throw std::invalid_argument("participant: '" + code + "' is not one of the study's (" + codes + ")");
      }
      // One loop drives the device: a free trial and a session never run at once.
      std::lock_guard lock(device_mutex_);
      if (tuning_.running()) throw ConsoleConflict("start: a free trial runs on the Tuning page; stop it first");
      session_.start(code, step);
    });
  }

  void add_tuning_controls(std::vector<Route>& op) {
    tuning_control(op, "/api/tuning/start", {"task", "from"}, [this](const nlohmann::json& body) {
      const std::string task = text_field(body, "task", 64);
      const std::string from = text_field(body, "from", 200);
      const NamedSettings* start = nullptr;
      std::string names;
      for (const NamedSettings& n : study_settings_.settings) {
        if (n.name == from) start = &n;
        names += (names.empty() ? "" : ", ") + ("'" + n.name + "'");
      }
      if (start == nullptr)
        throw std::invalid_argument("from: '" + from + "' is not a setting of the study (" + names + ")");
      std::lock_guard lock(device_mutex_);
      if (session_.running())
        throw ConsoleConflict("a session is running; the Tuning page is for pilot work outside one");
      tuning_.start(task, *start);
    });
    tuning_control(op, "/api/tuning/stop", {}, [this](const nlohmann::json&) { tuning_.stop(); });
    tuning_control(op, "/api/tuning/set", {"field", "value"}, [this](const nlohmann::json& body) {
      if (!body.contains("value"))
        throw std::invalid_argument("value: missing (a number, or true/false for \"enabled\")");
      tuning_.set(text_field(body, "field", 200), body["value"]);
    });
    tuning_control(op, "/api/tuning/save", {"name"},
                   [this](const nlohmann::json& body) { (void)tuning_.save(text_field(body, "name", 64)); });
  }

  // The session's other controls, and the results'.
  void add_other_controls(std::vector<Route>& op) {
    control(op, "/api/session/next", {}, [this](const nlohmann::json&) { session_.next_trial(); });
    control(op, "/api/session/pause", {"paused"},
            [this](const nlohmann::json& body) { session_.set_paused(bool_field(body, "paused", true)); });
    control(op, "/api/session/rest", {"seconds"}, [this](const nlohmann::json& body) {
      session_.rest(number_field(body, "seconds", 1.0, 3600.0));
    });
    control(op, "/api/session/end-training", {}, [this](const nlohmann::json&) { session_.end_training(); });
    control(op, "/api/session/abort", {"trial_id", "reason"}, [this](const nlohmann::json& body) {
      // The trial the operator saw running (0: none); absent: the one running now.
      std::optional<std::int64_t> trial_id;
      if (body.contains("trial_id")) trial_id = integer_field(body, "trial_id", 0, INT64_MAX, 0);
      session_.abort_trial(text_field(body, "reason", 500), trial_id);
    });
    control(op, "/api/results/export", {"participant", "every", "gzip"}, [this](const nlohmann::json& body) {
      const std::string participant = optional_text_field(body, "participant", 64, "", true);
      if (!participant.empty() && !known_participant(participant))
        throw std::invalid_argument("participant: '" + participant + "' is not one of the study's");
      const std::int64_t every = integer_field(body, "every", 1, 1000000, 1);
      results_.start_export(participant, static_cast<std::uint64_t>(every), bool_field(body, "gzip", true));
    });
    control(op, "/api/results/analyze", {"plots"},
            [this](const nlohmann::json& body) { results_.start(bool_field(body, "plots", true)); });
    control(op, "/api/session/note", {"text"},
            [this](const nlohmann::json& body) { session_.note(text_field(body, "text", 2000)); });
  }

  nlohmann::json tuning_view() const {
    nlohmann::json j = tuning_.status();
    j.erase("log");  // the page polls /api/tuning for it
    j.erase("settings");
    return j;
  }

  const ConsoleConfig& config_;
  OperatorActions actions_;
  OperatorActions stop_actions_;
  DeviceHealth device_health_;
  const sessions::StudyProgress at_start_;
  ConsoleSession session_;
  ConsoleResults results_;
  const StudySettings study_settings_;
  ConsoleTuning tuning_;
  const std::string chart_js_;
  std::mutex device_mutex_;  // starting a session or a free trial
  AccessTickets tickets_;
  int participant_port_ = 0;  // known once its site listens
  LiveCursor session_cursor_, tuning_cursor_;
  bool tuning_was_running_ = false;
};

http::ServerConfig server_config() {
  http::ServerConfig server_config;
  server_config.limits.max_body_bytes = kMaxBodyBytes;
  server_config.default_headers = {{"Cache-Control", "no-store"},
                                   {"X-Content-Type-Options", "nosniff"},
                                   {"X-Frame-Options", "DENY"},
                                   {"Content-Security-Policy", kPageCsp},
                                   {"Referrer-Policy", "no-referrer"}};
  return server_config;
}

}  // namespace

ConsoleOutcome serve_console(const ConsoleConfig& config, const std::atomic<bool>& stop) {
  if (config.token.size() < 16) throw std::invalid_argument("console token: shorter than 16 characters");
  Console console(config);
  http::Server server(server_config());
  console.add_streams(server);
  const int port = server.add_site({"operator", config.bind_address, config.port, console.operator_routes(),
                                    kOperatorConnections, kOperatorStreams});
  const int participant_port = server.add_site({"participant", config.bind_address, config.participant_port,
                                                console.participant_routes(), kParticipantConnections,
                                                kParticipantStreams});
  console.set_participant_port(participant_port);
  const std::string host = url_host(config.bind_address);
  if (!config.token_file.empty())
    std::printf("console token (controls need it): in %s (readable only by you) and in the address below\n",
                config.token_file.c_str());
  std::printf("console: http://%s:%d/#token=%s  (the operator's page; the token stays in the page)\n", host.c_str(),
              port, config.token.c_str());
  std::printf("participant screen: http://%s:%d/participant  (open it on the participant's display)\n", host.c_str(),
              participant_port);
  std::fflush(stdout);
  server.run(stop);
  return console.shut_down();
}

}  // namespace hapticlab::console
