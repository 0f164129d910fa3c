#pragma once
// How the command line reports failures, the same way for every command:
//
//   0    success
//   1    the command failed (a file, the database, a device); the message
//        on stderr says what and where
//   2    usage error: an unknown command or option, a bad value; stderr
//        has "hapticlab: error: ..." and which --help to read
//   3    session run / sim run / sim replay: a device fault ended the run
//   4    sim run: the task did not complete within the time limit
//   130  stopped by Ctrl-C (session run, demo: run it again to continue;
//        sim run, sim replay: their output file is not written)

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace hapticlab::app {

// The exit-status table above, for the top-level --help footer.
std::string exit_status_help();

// Parses and runs; returns the exit status above. Prints usage errors and
// uncaught exceptions itself.
int run_command_line(CLI::App& app, int argc, char** argv);

// The nearest of `candidates` to `word` (Levenshtein), if it is close
// enough to be a likely typo; empty otherwise.
std::string nearest_name(const std::string& word, const std::vector<std::string>& candidates);

// Adds `hapticlab help [COMMAND...]`.
void add_help_command(CLI::App& app);

}  // namespace hapticlab::app
