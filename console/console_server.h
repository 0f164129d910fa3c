#pragma once
// `hapticlab console`: the operator's web console for one study database,
// served by the console's own HTTP server (console/http/: one event loop,
// so STOP is answered whatever else is connected), pages embedded in the
// binary so it works offline. Two origins:
//   the operator's port: / (study, session controls, live plots, tuning,
//     results; it names settings) and every /api, /events/operator,
//     /results, /tuning route;
//   the participant's port: /participant (trial k of N, a cue, the task's
//     instructions; never a setting), its script and style, and its one
//     event stream, /events/participant; nothing else.
// A page of one origin cannot read the other's answers. On the operator's
// port only the page's shell and its scripts and styles are served without
// the token; every read that names a setting or a participant (/api/...,
// /events/operator, /results/..., /tuning/...) and every control needs it
// in the X-HapticLab-Token header (a header, not a cookie: another site's
// page cannot send it, and a cookie would go to the participant screen's
// port too), or, for a GET a browser must open by address, a one-time
// ticket (access_tickets.h). So a participant who types the operator's
// address into the screen's browser gets the shell and 403s.

#include <atomic>
#include <filesystem>
#include <optional>
#include <string>

#include "console/console_session.h"

namespace hapticlab::console {

struct ConsoleConfig {
  ConsoleSessionConfig session;
  std::string bind_address = "127.0.0.1";
  int port = 8080;                       // the operator's; 0: any free port (printed)
  int participant_port = 0;              // the participant screen's; 0: any free port (printed)
  std::string token;                     // required for every control request
  std::filesystem::path token_file;      // where the token is kept: printed with the address
  std::filesystem::path chart_js = "/usr/share/javascript/chart.js/chart.min.js";  // Debian libjs-chart.js
};

struct ConsoleOutcome {
  // The console's device hung (device_health.h): why. A thread of this
  // process is still inside the device's code; the caller must end the
  // process without waiting for it (std::_Exit, status 3).
  std::optional<std::string> device_hung;
};

// Serves until `stop` is set (seen within 50 ms). Prints both addresses to
// stdout once it listens (and not before, so a console that cannot listen
// promises no address), the operator's with the token in its fragment
// (#token=...: the page keeps it and takes it out of the address bar),
// after the line naming token_file.
// Throws std::runtime_error when it cannot listen (address in use, bad
// address) or the database has no study.
ConsoleOutcome serve_console(const ConsoleConfig& config, const std::atomic<bool>& stop);

// The embedded pages (console/web/*, built into console_assets.cc).
struct Asset {
  const char* path;          // "/", "/participant", "/console.js", ...
  const char* content_type;  // without the charset: every page is UTF-8
  const char* site;          // "operator" or "participant": the port that serves it
  const char* body;
};
extern const Asset kAssets[];
extern const std::size_t kAssetCount;

}  // namespace hapticlab::console
