#include "app/settings_check.h"

#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/settings/settings_json.h"

namespace hapticlab::app {

void add_settings_check_command(CLI::App& settings) {
  auto files = std::make_shared<std::vector<std::string>>();
  auto quiet = std::make_shared<bool>(false);
  CLI::App* cmd = settings.add_subcommand(
      "check", "Validate settings files; print the resolved parameters (defaults filled in)");
  cmd->add_option("files", *files, "Settings JSON files")->required()->check(CLI::ExistingFile);
  cmd->add_flag("-q,--quiet", *quiet, "Only report errors");
  settings.add_subcommand("reference", "Print every settings field with its default and range")
      ->callback([] { std::cout << settings_reference_markdown(); });
  cmd->callback([files, quiet] {
    for (const std::string& f : *files) {
      const NamedSettings s = load_settings_file(f);
      if (*quiet) continue;
      std::cout << "# " << f << ": ok\n" << settings_to_json(s).dump(2) << "\n";
    }
  });
}

}  // namespace hapticlab::app
