#include "app/engine/settings_check.h"

#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/settings/settings_json.h"

namespace hapticlab::app {

void add_settings_check_command(CLI::App& settings) {
  struct Options {
    std::vector<std::string> files;
    bool quiet = false;
    bool json = false;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = settings.add_subcommand(
      "check",
      "Validate settings files; print the resolved parameters (defaults filled in). Every file is checked; "
      "exit status 1 if any is invalid");
  // No ExistingFile check: it would stop the parse at the first missing
  // file, and every file is checked, a missing one as invalid (load_settings_file).
  cmd->add_option("--settings", opt->files, "Settings JSON file (repeatable)");
  // The old positional form, `settings check A.json B.json`, hidden.
  cmd->add_option("files", opt->files, "Settings JSON files")->group("");
  cmd->add_flag("-q,--quiet", opt->quiet, "Only report errors");
  cmd->add_flag("--json", opt->json,
                "Print one JSON array, an object per file: file, ok, and the resolved settings or the error");
  settings.add_subcommand("reference", "Print every settings field with its default and range")
      ->callback([] { std::cout << settings_reference_markdown(); });
  cmd->callback([opt] {
    if (opt->files.empty()) throw CLI::RequiredError("--settings");
    nlohmann::json results = nlohmann::json::array();
    int failed = 0;
    for (const std::string& f : opt->files) {
      try {
        const NamedSettings s = load_settings_file(f);
        if (opt->json) results.push_back({{"file", f}, {"ok", true}, {"settings", settings_to_json(s)}});
        else if (!opt->quiet)
          std::cout << "# " << f << ": ok\n"
                    << (s.source ? source_text(*s.source) : std::string()) << settings_to_json(s).dump(2) << "\n";
      } catch (const std::exception& e) {
        ++failed;
        if (opt->json) results.push_back({{"file", f}, {"ok", false}, {"error", e.what()}});
        std::fprintf(stderr, "hapticlab: error: %s\n", e.what());
      }
    }
    if (opt->json) std::cout << results.dump(2) << "\n";
    if (failed > 0) throw CLI::RuntimeError(1);
  });
}

}  // namespace hapticlab::app
