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
// A page of one origin cannot read the other's answers, so a participant
// who browses from the screen cannot reach what names the setting.
// Reads need nothing but the right Host; every control (POST /api/...)
// needs the token in the X-HapticLab-Token header (a header, not a cookie:
// another site's page cannot send it, which blocks cross-site requests).

#include <atomic>
#include <filesystem>
#include <string>

#include "console/console_session.h"

namespace hapticlab::console {

struct ConsoleConfig {
  ConsoleSessionConfig session;
  std::string bind_address = "127.0.0.1";
  int port = 8080;                       // the operator's; 0: any free port (printed)
  int participant_port = 0;              // the participant screen's; 0: any free port (printed)
  std::string token;                     // required for every control request
  std::filesystem::path chart_js = "/usr/share/javascript/chart.js/chart.min.js";  // Debian libjs-chart.js
};

// Serves until `stop` is set (seen within 50 ms). Prints both addresses to
// stdout once it listens, the operator's with the token in its fragment
// (#token=...: the page keeps it and takes it out of the address bar).
// Throws std::runtime_error when it cannot listen (address in use, bad
// address) or the database has no study.
void serve_console(const ConsoleConfig& config, const std::atomic<bool>& stop);

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
