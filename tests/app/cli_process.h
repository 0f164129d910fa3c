#pragma once
// Runs the real `hapticlab` binary as a user would, for the tests that check
// what a command prints and how it exits.

#include <sys/wait.h>

#include <cstdio>
#include <string>
#include <utility>

namespace hapticlab::testing {

// Runs `binary args` with stderr folded into stdout; returns the exit status
// (-1 if it did not exit normally) and everything it printed.
inline std::pair<int, std::string> run_cli(const std::string& binary, const std::string& args) {
  const std::string command = binary + " " + args + " 2>&1";
  std::FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return {-1, "popen failed"};
  std::string out;
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
  const int status = ::pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

}  // namespace hapticlab::testing
