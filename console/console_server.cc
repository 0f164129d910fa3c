#include "console/console_server.h"

#include <httplib.h>

#include <array>
#include <algorithm>
#include <chrono>
#include <mutex>
#include <set>
#include <fstream>
#include <memory>
#include <optional>
#include <cstdio>
#include <stdexcept>
#include <thread>

#include "console/console_results.h"
#include "console/console_tuning.h"
#include "protocols/safety_json.h"
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

// Bounds on what the console reads into memory to serve.
constexpr std::size_t kMaxChartJsBytes = 16u << 20;

// A file of a folder the console writes (served_file.h), streamed in pieces:
// a study's sample export is hundreds of megabytes.
void serve_download(const std::optional<std::filesystem::path>& path, const std::string& name,
                    httplib::Response& res) {
  std::error_code ec;
  const auto size = path ? std::filesystem::file_size(*path, ec) : 0;
  if (!path || ec) {
    error_reply(res, 404, "no such file: " + name);
    return;
  }
  const std::string file = path->filename().string();
  const char* type = file.ends_with(".html")  ? "text/html; charset=utf-8"
                     : file.ends_with(".svg") ? "image/svg+xml"
                     : file.ends_with(".csv") ? "text/csv; charset=utf-8"
                     : file.ends_with(".gz")  ? "application/gzip"
                     : file.ends_with(".json") ? "application/json"
                                               : "text/plain; charset=utf-8";
  if (!file.ends_with(".html") && !file.ends_with(".svg"))
    res.set_header("Content-Disposition", "attachment; filename=\"" + file + "\"");
  res.set_header("Cache-Control", "no-store");
  auto in = std::make_shared<std::ifstream>(*path, std::ios::binary);
  if (!*in) {
    error_reply(res, 500, "cannot read " + name);
    return;
  }
  res.set_content_provider(static_cast<std::size_t>(size), type,
                           [in](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
                             std::array<char, 1 << 16> buffer;
                             in->seekg(static_cast<std::streamoff>(offset));
                             const auto n = std::min(length, buffer.size());
                             in->read(buffer.data(), static_cast<std::streamsize>(n));
                             const auto got = static_cast<std::size_t>(in->gcount());
                             // A file cut short while served: end the response rather than spin.
                             return got > 0 && sink.write(buffer.data(), got);
                           });
}

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
  // The study's settings and tasks, which a free trial on the Tuning page starts from.
  const StudySettings study_settings = read_study_settings(config.session.db, at_start);
  ConsoleTuningConfig tuning_config;
  tuning_config.device = config.session.device;
  tuning_config.realtime = config.session.realtime;
  tuning_config.clock = ClockKind::kWall;  // a free trial is felt (or watched) as it happens
  tuning_config.force_limits =
      protocols::safety_from_protocol_text(at_start.study.protocol_json, config.session.db.string());
  tuning_config.out_dir = config.session.db.parent_path() / (config.session.db.stem().string() + "-console-tuning");
  ConsoleTuning tuning(tuning_config);
  const std::string chart_js = std::filesystem::exists(config.chart_js)
                                   ? read_text_file(config.chart_js, kMaxChartJsBytes, "Chart.js file")
                                   : std::string();

  std::mutex device_mutex;  // starting a session or a free trial
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
  server.Get("/api/tuning", [&](const httplib::Request&, httplib::Response& res) {
    nlohmann::json j = tuning.status();
    j["reference"] = ConsoleTuning::reference()["fields"];
    j["study_settings"] = nlohmann::json::array();
    for (const NamedSettings& n : study_settings.settings) j["study_settings"].push_back(n.name);
    j["tasks"] = study_settings.tasks;
    json_reply(res, j);
  });
  server.Get(R"(/tuning/(.+))", [&](const httplib::Request& req, httplib::Response& res) {
    serve_download(tuning.file(req.matches[1]), req.matches[1], res);
  });
  server.Get("/api/results", [&](const httplib::Request&, httplib::Response& res) {
    json_reply(res, results.status());
  });
  server.Get(R"(/results/(.+))", [&](const httplib::Request& req, httplib::Response& res) {
    serve_download(results.file(req.matches[1]), req.matches[1], res);
  });
  // Server-sent events: the operator's live stream (plots and status) and
  // the participant's (cue, trial k of N).
  // Live plots and status, of the session (/events/live) or of the free
  // trial on the Tuning page (/events/tuning): only points not sent yet.
  const auto live_stream = [&](const char* path, auto status_of, auto points_of, const char* repetition_key) {
    server.Get(path, [&, status_of, points_of, repetition_key](const httplib::Request&, httplib::Response& res) {
      res.set_header("Cache-Control", "no-store");
      res.set_chunked_content_provider(
          "text/event-stream", [&, status_of, points_of, repetition_key, last_t = std::array<double, 2>{-1.0, -1.0},
                                last_repetition = -1](std::size_t, httplib::DataSink& sink) mutable {
            if (stop.load()) return false;
            const nlohmann::json status = status_of();
            const int repetition = status.value(repetition_key, 0);
            if (repetition != last_repetition) last_t = {-1.0, -1.0}, last_repetition = repetition;
            const auto points = points_of(std::min(last_t[0], last_t[1]));
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
  };
  live_stream(
      "/events/live", [&] { return session.operator_status(); },
      [&](double after_t_s) { return session.live_since(after_t_s); }, "trial_number");
  live_stream(
      "/events/tuning",
      [&] {
        nlohmann::json j = tuning.status();
        j.erase("log");  // the page polls /api/tuning for it
        j.erase("settings");
        return j;
      },
      [&](double after_t_s) { return tuning.live_since(after_t_s); }, "free_trial");
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
  const auto control_replying = [&](const std::string& path, auto action, auto reply) {
    server.Post(path, [&, action, reply](const httplib::Request& req, httplib::Response& res) {
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
        json_reply(res, reply());
      } catch (const std::invalid_argument& e) {
        error_reply(res, 400, e.what());
      } catch (const std::exception& e) {
        error_reply(res, 500, e.what());
      }
    });
  };
  const auto control = [&](const std::string& path, auto action) {
    control_replying(path, action, [&] { return session.operator_status(); });
  };
  const auto tuning_control = [&](const std::string& path, auto action) {
    control_replying(path, action, [&] { return tuning.status(); });
  };
  const auto known_participant = [&](const std::string& code) {
    for (const auto& p : at_start.participants)
      if (p.code == code) return true;
    return false;
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
    if (!known_participant(code)) {
      std::string codes;
      for (const auto& p : at_start.participants) codes += (codes.empty() ? "" : ", ") + p.code;
      throw std::invalid_argument("participant: '" + code + "' is not one of the study's (" + codes + ")");
    }
    // One loop drives the device: a free trial and a session never run at once.
    std::lock_guard lock(device_mutex);
    if (tuning.running()) throw std::invalid_argument("a free trial runs on the Tuning page; stop it first");
    session.start(code, body.value("step", false));
  });
  // STOP stops whatever drives the device.
  control("/api/session/stop", [&](const nlohmann::json&) {
    session.stop();
    tuning.stop();
  });
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
    if (session.running()) throw std::invalid_argument("a session is running; the Tuning page is for pilot work outside one");
    tuning.start(task, *start);
  });
  tuning_control("/api/tuning/stop", [&](const nlohmann::json&) { tuning.stop(); });
  tuning_control("/api/tuning/set", [&](const nlohmann::json& body) {
    if (!body.contains("value")) throw std::invalid_argument("value: missing (a number, or true/false for \"enabled\")");
    tuning.set(text_field(body, "field", 200), body["value"]);
  });
  tuning_control("/api/tuning/save", [&](const nlohmann::json& body) { (void)tuning.save(text_field(body, "name", 64)); });
  control("/api/session/next", [&](const nlohmann::json&) { session.next_trial(); });
  control("/api/session/pause", [&](const nlohmann::json& body) { session.set_paused(body.value("paused", true)); });
  control("/api/session/rest", [&](const nlohmann::json& body) {
    if (!body.contains("seconds") || !body["seconds"].is_number())
      throw std::invalid_argument("seconds: missing (a number of seconds, 1..3600)");
    session.rest(body["seconds"].get<double>());
  });
  control("/api/session/end-training", [&](const nlohmann::json&) { session.end_training(); });
  control("/api/session/abort", [&](const nlohmann::json& body) {
    // The trial the operator saw running (0: none); absent: the one running now.
    std::optional<std::int64_t> trial_id;
    if (body.contains("trial_id")) {
      if (!body["trial_id"].is_number_integer())
        throw std::invalid_argument("trial_id: " + body["trial_id"].dump() + ", must be a trial's id (/api/status)");
      trial_id = body["trial_id"].get<std::int64_t>();
    }
    session.abort_trial(text_field(body, "reason", 500), trial_id);
  });
  control("/api/results/export", [&](const nlohmann::json& body) {
    const std::string participant = body.value("participant", std::string());
    if (!participant.empty() && !known_participant(participant))
      throw std::invalid_argument("participant: '" + participant + "' is not one of the study's");
    const auto every = body.value("every", 1);
    if (every < 1) throw std::invalid_argument("every: " + std::to_string(every) + ", must be >= 1");
    results.start_export(participant, static_cast<std::uint64_t>(every), body.value("gzip", true));
  });
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
    tuning.stop();
    server.stop();
  });
  server.listen_after_bind();
  watcher.join();
}

}  // namespace hapticlab::console
