#pragma once
// `hapticlab console`: the operator's web console for one study database,
// served over HTTP by cpp-httplib (pages embedded in the binary, so it works
// offline). Pages: / (study, session controls, live plots, tuning, results;
// the operator's view, which names settings) and /participant (the participant's screen:
// trial k of N, a ready/go/done cue, the task's instructions; never a
// setting). Read-only requests need nothing; every control (POST /api/...)
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
  int port = 8080;                       // 0: any free port (printed)
  std::string token;                     // required for every control request
  std::filesystem::path chart_js = "/usr/share/javascript/chart.js/chart.min.js";  // Debian libjs-chart.js
};

// Serves until `stop` is set (checked every 100 ms). Prints the address it
// listens on to stdout once it does. Throws std::runtime_error when it
// cannot listen (address in use, bad address) or the database has no study.
void serve_console(const ConsoleConfig& config, const std::atomic<bool>& stop);

// The embedded pages (console/web/*, built into console_assets.cc).
struct Asset {
  const char* path;          // "/", "/participant", "/console.js", ...
  const char* content_type;  // without the charset: every page is UTF-8
  const char* body;
};
extern const Asset kAssets[];
extern const std::size_t kAssetCount;

}  // namespace hapticlab::console
