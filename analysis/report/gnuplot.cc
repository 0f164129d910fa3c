#include "analysis/report/gnuplot.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "analysis/stats/data_error.h"
#include "core/io/output_file.h"

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

namespace {
constexpr const char* kOkabeItoLinetypes =
    "set linetype 1 lc rgb '#0072B2'\nset linetype 2 lc rgb '#D55E00'\nset linetype 3 lc rgb '#009E73'\n"
    "set linetype 4 lc rgb '#CC79A7'\nset linetype 5 lc rgb '#9A6700'\nset linetype 6 lc rgb '#AA4499'\n"
    "set linetype 7 lc rgb '#000000'\nset linetype 8 lc rgb '#6F6F6F'\nset linetype cycle 8\n";
}  // namespace

std::string inline_svg(const std::string& svg, const std::string& id_prefix) {
  const auto start = svg.find("<svg");
  const std::string body = start == std::string::npos ? svg : svg.substr(start);
  // Attribute values that name an id, in both quote styles gnuplot uses.
  static const std::vector<std::string> openers = {"id=\"", "id='", "href=\"#", "href='#", "url(#"};
  std::string out;
  out.reserve(body.size() + 64);
  std::size_t i = 0;
  while (i < body.size()) {
    std::size_t best = std::string::npos;
    std::size_t best_len = 0;
    for (const auto& o : openers) {
      std::size_t at = body.find(o, i);
      // " id=" only: "grid=" or "xml:id" inside other names must not match.
      while (o[0] == 'i' && at != std::string::npos && at > 0 && body[at - 1] != ' ' && body[at - 1] != '\t' &&
             body[at - 1] != '\n') {
        at = body.find(o, at + 1);
      }
      if (at < best) {
        best = at;
        best_len = o.size();
      }
    }
    if (best == std::string::npos) {
      out.append(body, i, std::string::npos);
      break;
    }
    out.append(body, i, best - i + best_len);
    out += id_prefix;
    i = best + best_len;
  }
  return out;
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
           " font 'Helvetica,14' background rgb 'white'\n";
  // Okabe & Ito's colour-blind-safe colours, without their yellow (1.1:1
  // against white); gnuplot's default line type 5 is that yellow.
  text_ += kOkabeItoLinetypes;
  text_ += "set output " + gnuplot_quote(svg_name) + "\n";
  text_ += commands;
  if (!commands.empty() && commands.back() != '\n') text_ += '\n';
  text_ += "unset output\n";
  outputs_.push_back(svg_name);
  if (pdf_) {
    const std::string pdf_name = svg_name.substr(0, svg_name.rfind('.')) + ".pdf";
    char size[64];
    std::snprintf(size, sizeof size, "%.2fin,%.2fin", width_px / 96.0, height_px / 96.0);
    text_ += "set terminal pdfcairo size " + std::string(size) + " font 'Helvetica,10'\n";
    text_ += "set output " + gnuplot_quote(pdf_name) + "\nreplot\nunset output\n";
    pdf_outputs_.push_back(pdf_name);
  }
}

namespace {

// Removes the staging directory on every path out of run_gnuplot.
class StagingDir {
 public:
  explicit StagingDir(std::filesystem::path path) : path_(std::move(path)) {
    std::filesystem::remove_all(path_);
    std::error_code ec;
    std::filesystem::create_directories(path_, ec);
    if (ec) throw DataError("cannot create the directory '" + path_.string() + "' for the figures: " + ec.message());
  }
  StagingDir(const StagingDir&) = delete;
  StagingDir& operator=(const StagingDir&) = delete;
  ~StagingDir() {
    std::error_code ignored;  // best effort: a destructor must not throw
    std::filesystem::remove_all(path_, ignored);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Whether the last `tail` bytes of the file hold `marker`. gnuplot does not
// always fail when its output cannot be written (a full disk truncates the
// file and gnuplot still exits 0), so a figure counts only when its end made
// it to the file: an SVG's closing tag, a PDF's %%EOF.
bool ends_with_marker(const std::filesystem::path& path, const std::string& marker, std::streamoff tail_bytes) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return false;
  const std::streamoff size = in.tellg();
  const std::streamoff tail = std::min<std::streamoff>(size, tail_bytes);
  std::string end(static_cast<std::size_t>(tail), '\0');
  in.seekg(size - tail);
  in.read(end.data(), tail);
  return in && end.find(marker) != std::string::npos;
}

bool complete_svg(const std::filesystem::path& path) { return ends_with_marker(path, "</svg>", 64); }
bool complete_pdf(const std::filesystem::path& path) { return ends_with_marker(path, "%%EOF", 32); }

}  // namespace

void run_gnuplot(const GnuplotScript& script, const std::filesystem::path& dir,
                 const std::filesystem::path& gnuplot) {
  // gnuplot draws into a staging directory; the figures and the script move
  // into `dir` only when every one is complete, so a failed run (disk full,
  // a gnuplot error) leaves no truncated figure that looks like a result.
  const StagingDir staging(std::filesystem::absolute(dir) / (".plots." + std::to_string(::getpid()) + ".tmp"));
  const std::filesystem::path script_path = staging.path() / "plots.gp";
  const std::filesystem::path log_path = staging.path() / "gnuplot.log";
  try {
    write_file_atomically(script_path, script.text());
  } catch (const OutputFileError& e) {
    throw DataError(std::string("cannot write the plot script: ") + e.what());
  }

  // posix_spawn rather than system(): no shell, so no quoting of paths.
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  // Output names in the script are relative to its directory, so it reruns there by hand.
  const std::string dir_text = staging.path().string();
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
  const std::filesystem::path final_script = dir / "plots.gp";
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw DataError("gnuplot failed on " + final_script.string() +
                    (WIFSIGNALED(status) ? std::string(" (killed by signal ") + std::to_string(WTERMSIG(status)) + ")"
                                         : std::string()) +
                    ": " + messages.str());
  }
  for (const auto& name : script.outputs()) {
    if (!complete_svg(staging.path() / name)) {
      throw DataError("gnuplot wrote no complete " + (dir / name).string() + " (disk full?): " + messages.str());
    }
  }
  for (const auto& name : script.pdf_outputs()) {
    if (!complete_pdf(staging.path() / name)) {
      throw DataError("gnuplot wrote no complete " + (dir / name).string() + " (disk full, or no pdfcairo "
                      "terminal in this gnuplot?): " + messages.str());
    }
  }
  for (const auto& name : script.outputs()) std::filesystem::rename(staging.path() / name, dir / name);
  for (const auto& name : script.pdf_outputs()) std::filesystem::rename(staging.path() / name, dir / name);
  std::filesystem::rename(script_path, final_script);
}

}  // namespace hapticlab::analysis
