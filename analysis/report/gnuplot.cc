#include "analysis/report/gnuplot.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "analysis/stats/data_error.h"

extern char** environ;

namespace hapticlab::analysis {

std::filesystem::path find_gnuplot() {
  if (const char* env = std::getenv("HAPTICLAB_GNUPLOT"); env != nullptr && *env != '\0') {
    if (::access(env, X_OK) == 0) return env;
    throw DataError(std::string("HAPTICLAB_GNUPLOT is '") + env + "', but that is not an executable file");
  }
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path != nullptr ? path : "/usr/bin:/bin");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    if (dir.empty()) continue;
    const std::filesystem::path candidate = std::filesystem::path(dir) / "gnuplot";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  throw DataError("gnuplot was not found on PATH; the report's plots need it: install the Debian package "
                  "gnuplot-nox (apt-get install gnuplot-nox, or run scripts/setup.sh), set HAPTICLAB_GNUPLOT "
                  "to its path, or pass --no-plots");
}

std::string gnuplot_quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + '"';
}

void GnuplotScript::add_datablock(const std::string& name, const std::string& rows) {
  text_ += "$" + name + " << EOD\n" + rows;
  if (!rows.empty() && rows.back() != '\n') text_ += '\n';
  text_ += "EOD\n";
}

void GnuplotScript::add_plot(const std::string& svg_name, const std::string& commands, int width_px,
                             int height_px) {
  text_ += "reset\n";
  text_ += "set terminal svg size " + std::to_string(width_px) + "," + std::to_string(height_px) +
           " font 'Helvetica,12' background rgb 'white'\n";
  text_ += "set output " + gnuplot_quote(svg_name) + "\n";
  text_ += commands;
  if (!commands.empty() && commands.back() != '\n') text_ += '\n';
  text_ += "unset output\n";
  outputs_.push_back(svg_name);
}

void run_gnuplot(const GnuplotScript& script, const std::filesystem::path& dir,
                 const std::filesystem::path& gnuplot) {
  const std::filesystem::path script_path = std::filesystem::absolute(dir / "plots.gp");
  const std::filesystem::path log_path = std::filesystem::absolute(dir / "gnuplot.log");
  {
    std::ofstream out(script_path, std::ios::binary | std::ios::trunc);
    out << script.text();
    if (!out) throw DataError("cannot write the plot script '" + script_path.string() + "'");
  }
  for (const auto& name : script.outputs()) std::filesystem::remove(dir / name);

  // posix_spawn rather than system(): no shell, so no quoting of paths.
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  // Output names in the script are relative to its directory, so it reruns there by hand.
  const std::string dir_text = std::filesystem::absolute(dir).string();
  posix_spawn_file_actions_addchdir_np(&actions, dir_text.c_str());
  const std::string program = gnuplot.string();
  const std::string script_arg = script_path.string();
  char* argv[] = {const_cast<char*>(program.c_str()), const_cast<char*>(script_arg.c_str()), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, program.c_str(), &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) {
    throw DataError("cannot start gnuplot '" + program + "': " + std::strerror(spawned));
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) throw DataError(std::string("waiting for gnuplot failed: ") + std::strerror(errno));
  }
  std::ifstream log(log_path);
  std::stringstream messages;
  messages << log.rdbuf();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw DataError("gnuplot failed on " + script_path.string() + ": " + messages.str());
  }
  for (const auto& name : script.outputs()) {
    if (!std::filesystem::exists(dir / name)) {
      throw DataError("gnuplot wrote no " + (dir / name).string() + ": " + messages.str());
    }
  }
  std::filesystem::remove(log_path);
}

}  // namespace hapticlab::analysis
