#pragma once
// One name for one thing across commands (--out for outputs, --csv for a CSV
// input, --max-trial-s for a time limit, --settings for settings files):
// an option renamed to follow that keeps its old spelling for one release,
// accepted but hidden from --help.

#include <string>

#include <CLI/CLI.hpp>

namespace hapticlab::app {

struct RenamedOption {
  CLI::Option* current = nullptr;
  CLI::Option* old = nullptr;

  // For an option that must be given under either name: a usage error (exit
  // status 2) naming the current spelling when neither was. Call it in the
  // command's callback; CLI11's required() would refuse the old spelling.
  void require() const {
    if (current->count() == 0 && old->count() == 0) throw CLI::RequiredError(current->get_name());
  }
};

// Adds `old_name` as a hidden spelling of `current`, writing to the same
// variable; giving both is a usage error. Checks (ExistingFile, ranges) are
// the caller's to add to `.old` as to `.current`.
template <typename T>
RenamedOption add_old_spelling(CLI::App& cmd, CLI::Option* current, const std::string& old_name, T& target) {
  CLI::Option* old = cmd.add_option(old_name, target, "Old spelling of " + current->get_name() + " (until 0.3)");
  old->group("");  // hidden
  old->excludes(current);
  // One way suffices (CLI11 checks the excludes of every option given), and
  // the other would print "Excludes:" under the current spelling with the
  // hidden one's name left out.
  current->remove_excludes(old);
  return {current, old};
}

}  // namespace hapticlab::app
