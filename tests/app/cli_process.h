#pragma once
// Runs the real `hapticlab` binary as a user would, for the tests that check
// what a command prints and how it exits.

#include <sys/wait.h>

#include <cstdio>
#include <string>
#include <utility>

namespace hapticlab::testing {

// Runs a shell command; returns the exit status (-1 if it did not exit
// normally) and what it printed on stdout.
inline std::pair<int, std::string> run_shell(const std::string& command) {
  std::FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return {-1, "popen failed"};
  std::string out;
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
  const int status = ::pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

// Runs `binary args` with stderr folded into stdout.
inline std::pair<int, std::string> run_cli(const std::string& binary, const std::string& args) {
  return run_shell(binary + " " + args + " 2>&1");
}

// stdout alone (stderr discarded): for --json, whose stdout must parse.
inline std::pair<int, std::string> run_cli_stdout(const std::string& binary, const std::string& args) {
  return run_shell(binary + " " + args + " 2>/dev/null");
}

}  // namespace hapticlab::testing
