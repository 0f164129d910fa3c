#include "console/console_server.h"

#include <httplib.h>

#include <chrono>
#include <cstdio>
#include <stdexcept>
#include <thread>

#include "console/console_results.h"
#include "core/io/input_file.h"
#include "db/study_db.h"
#include "sessions/study_progress.h"

namespace hapticlab::console {
namespace {

constexpr std::size_t kMaxBodyBytes = 16 * 1024;  // notes and reasons are short
constexpr auto kLivePeriod = std::chrono::milliseconds(33);  // >= 30 Hz to the plots

// Compares without an early exit, so the time taken does not tell how much
// of a guessed token was right.
bool same_token(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (std::size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

void json_reply(httplib::Response& res, const nlohmann::json& j, int status = 200) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(j.dump(), "application/json");
}

void error_reply(httplib::Response& res, int status, const std::string& message) {
  json_reply(res, {{"error", message}}, status);
}

sessions::StudyProgress read_progress(const std::filesystem::path& db_path) {
  db::OpenOptions open;
  open.read_only = true;  // a session may be writing: change nothing
  open.integrity = db::OpenOptions::Integrity::kSkip;  // per request; `study check` does the full one
  db::StudyDb db(db_path, open);
  return sessions::study_progress(db);
}

// Bounds on what the console reads into memory to serve.
constexpr std::size_t kMaxChartJsBytes = 16u << 20;
constexpr std::size_t kMaxResultFileBytes = 512u << 20;  // a report with every figure inline

}  // namespace

void serve_console(const ConsoleConfig& config, const std::atomic<bool>& stop) {
  if (config.token.size() < 16) throw std::invalid_argument("console token: shorter than 16 characters");
  // The participants and settings of the study, read once: codes a request
  // may name, and (for the operator's page) the protocol summary.
  const sessions::StudyProgress at_start = read_progress(config.session.db);
  ConsoleSession session(config.session);
  // Next to the database: STUDY.db -> STUDY-console-analysis/.
  ConsoleResults results(config.session.db,
                         config.session.db.parent_path() / (config.session.db.stem().string() + "-console-analysis"));
  const std::string chart_js = std::filesystem::exists(config.chart_js)
                                   ? read_text_file(config.chart_js, kMaxChartJsBytes, "Chart.js file")
                                   : std::string();

  httplib::Server server;
  server.new_task_queue = [] { return new httplib::ThreadPool(16); };  // SSE streams hold a thread each
  server.set_payload_max_length(kMaxBodyBytes);

  for (std::size_t i = 0; i < kAssetCount; ++i) {
    const Asset& a = kAssets[i];
    server.Get(a.path, [a](const httplib::Request&, httplib::Response& res) {
      res.set_header("Cache-Control", "no-store");
      res.set_content(a.body, std::string(a.content_type) + "; charset=utf-8");
    });
  }
  server.Get("/vendor/chart.js", [&chart_js](const httplib::Request&, httplib::Response& res) {
    if (chart_js.empty()) {
      res.status = 404;
      res.set_content("// chart.js not installed (Debian: apt install libjs-chart.js)", "text/javascript");
      return;
    }
    res.set_content(chart_js, "text/javascript");
  });

  // --- read-only
  server.Get("/api/study", [&](const httplib::Request&, httplib::Response& res) {
    try {
      json_reply(res, sessions::study_progress_json(read_progress(config.session.db)));
    } catch (const std::exception& e) {
      error_reply(res, 500, e.what());
    }
  });
  server.Get("/api/status", [&](const httplib::Request&, httplib::Response& res) {
    json_reply(res, session.operator_status());
  });
  server.Get("/api/participant", [&](const httplib::Request&, httplib::Response& res) {
    json_reply(res, session.participant_status());
  });
  server.Get("/api/results", [&](const httplib::Request&, httplib::Response& res) {
    json_reply(res, results.status());
  });
  server.Get(R"(/results/(.+))", [&](const httplib::Request& req, httplib::Response& res) {
    const auto path = results.file(req.matches[1]);
    if (!path) {
      error_reply(res, 404, "no such result file: " + std::string(req.matches[1]));
      return;
    }
    const std::string name = path->filename().string();
    const char* type = name.ends_with(".html")  ? "text/html; charset=utf-8"
                       : name.ends_with(".svg") ? "image/svg+xml"
                       : name.ends_with(".csv") ? "text/csv; charset=utf-8"
                                                : "text/plain; charset=utf-8";
    if (name.ends_with(".csv") || name.ends_with(".md"))
      res.set_header("Content-Disposition", "attachment; filename=\"" + name + "\"");
    try {
      res.set_content(read_text_file(*path, kMaxResultFileBytes, "result file"), type);
    } catch (const std::exception& e) {
      error_reply(res, 500, e.what());
    }
  });
  // Server-sent events: the operator's live stream (plots and status) and
  // the participant's (cue, trial k of N).
  server.Get("/events/live", [&](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_chunked_content_provider("text/event-stream", [&, last_t = std::array<double, 2>{-1.0, -1.0},
                                                           last_trial = -1](std::size_t, httplib::DataSink& sink) mutable {
      if (stop.load()) return false;
      const nlohmann::json status = session.operator_status();
      const int trial = status.value("trial_number", 0);
      if (trial != last_trial) last_t = {-1.0, -1.0}, last_trial = trial;
      const auto points = session.live_since(std::min(last_t[0], last_t[1]));
      nlohmann::json j = {{"status", status}, {"instruments", nlohmann::json::array()}};
      for (std::size_t k = 0; k < 2; ++k) {
        nlohmann::json series = nlohmann::json::array();
        for (const LivePoint& p : points[k]) {
          if (p.t_s <= last_t[k]) continue;
          series.push_back({p.t_s, p.tip_force_N, p.displayed_force_N, p.insertion_m, p.pitch_rad, p.yaw_rad});
          last_t[k] = p.t_s;
        }
        j["instruments"].push_back(series);
      }
      const std::string msg = "data: " + j.dump() + "\n\n";
      if (!sink.write(msg.data(), msg.size())) return false;
      std::this_thread::sleep_for(kLivePeriod);
      return true;
    });
  });
  server.Get("/events/participant", [&](const httplib::Request&, httplib::Response& res) {
    res.set_header("Cache-Control", "no-store");
    res.set_chunked_content_provider("text/event-stream", [&](std::size_t, httplib::DataSink& sink) {
      if (stop.load()) return false;
      const std::string msg = "data: " + session.participant_status().dump() + "\n\n";
      if (!sink.write(msg.data(), msg.size())) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      return true;
    });
  });

  // --- controls: token first, then the body
  const auto control = [&](const std::string& path, auto action) {
    server.Post(path, [&, action](const httplib::Request& req, httplib::Response& res) {
      if (!same_token(req.get_header_value("X-HapticLab-Token"), config.token)) {
        error_reply(res, 403, "missing or wrong X-HapticLab-Token header (printed when the console started)");
        return;
      }
      nlohmann::json body = nlohmann::json::object();
      if (!req.body.empty()) {
        body = nlohmann::json::parse(req.body, nullptr, false);
        if (body.is_discarded() || !body.is_object()) {
          error_reply(res, 400, "request body: not a JSON object");
          return;
        }
      }
      try {
        action(body);
        json_reply(res, session.operator_status());
      } catch (const std::invalid_argument& e) {
        error_reply(res, 400, e.what());
      } catch (const std::exception& e) {
        error_reply(res, 500, e.what());
      }
    });
  };
  const auto text_field = [](const nlohmann::json& body, const char* name, std::size_t max) {
    if (!body.contains(name) || !body[name].is_string())
      throw std::invalid_argument(std::string(name) + ": missing (a string of 1.." + std::to_string(max) +
                                  " characters)");
    const std::string v = body[name].get<std::string>();
    if (v.empty() || v.size() > max)
      throw std::invalid_argument(std::string(name) + ": " + std::to_string(v.size()) + " characters, must be 1.." +
                                  std::to_string(max));
    return v;
  };
  control("/api/session/start", [&](const nlohmann::json& body) {
    const std::string code = text_field(body, "participant", 64);
    bool known = false;
    for (const auto& p : at_start.participants) known = known || p.code == code;
    if (!known) {
      std::string codes;
      for (const auto& p : at_start.participants) codes += (codes.empty() ? "" : ", ") + p.code;
      throw std::invalid_argument("participant: '" + code + "' is not one of the study's (" + codes + ")");
    }
    session.start(code, body.value("step", false));
  });
  control("/api/session/stop", [&](const nlohmann::json&) { session.stop(); });
  control("/api/session/next", [&](const nlohmann::json&) { session.next_trial(); });
  control("/api/session/pause", [&](const nlohmann::json& body) { session.set_paused(body.value("paused", true)); });
  control("/api/session/end-training", [&](const nlohmann::json&) { session.end_training(); });
  control("/api/session/abort", [&](const nlohmann::json& body) { session.abort_trial(text_field(body, "reason", 500)); });
  control("/api/results/analyze", [&](const nlohmann::json& body) { results.start(body.value("plots", true)); });
  control("/api/session/note", [&](const nlohmann::json& body) { session.note(text_field(body, "text", 2000)); });

  const int port = config.port == 0 ? server.bind_to_any_port(config.bind_address)
                                    : (server.bind_to_port(config.bind_address, config.port) ? config.port : -1);
  if (port < 0)
    throw std::runtime_error("console: cannot listen on " + config.bind_address + ":" + std::to_string(config.port) +
                             " (in use, or not an address of this machine)");
  std::printf("console: http://%s:%d/  (participant screen: http://%s:%d/participant)\n", config.bind_address.c_str(),
              port, config.bind_address.c_str(), port);
  std::fflush(stdout);
  std::thread watcher([&] {
    while (!stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    session.stop();
    server.stop();
  });
  server.listen_after_bind();
  watcher.join();
}

}  // namespace hapticlab::console
