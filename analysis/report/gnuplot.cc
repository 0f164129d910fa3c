#include "analysis/report/gnuplot.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <thread>

#include "analysis/stats/data_error.h"
#include "core/common/output_file.h"

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
  std::string text = "$" + name + " << EOD\n" + rows;
  if (!rows.empty() && rows.back() != '\n') text += '\n';
  text += "EOD\n";
  order_.emplace_back(false, blocks_.size());
  blocks_.push_back({name, std::move(text)});
}

namespace {

// Whether `commands` names the datablock: "$name" not followed by a letter,
// digit or '_' (so $d1 does not count as naming $d10's prefix).
bool names_block(const std::string& commands, const std::string& name) {
  const std::string needle = "$" + name;
  for (auto at = commands.find(needle); at != std::string::npos; at = commands.find(needle, at + 1)) {
    const std::size_t after = at + needle.size();
    if (after == commands.size()) return true;
    const auto c = static_cast<unsigned char>(commands[after]);
    if (!std::isalnum(c) && c != '_') return true;
  }
  return false;
}

}  // namespace

void GnuplotScript::add_plot(const std::string& svg_name, const std::string& commands, int width_px,
                             int height_px) {
  Plot plot;
  std::string& t = plot.text;
  t += "reset\n";
  t += "set terminal svg size " + std::to_string(width_px) + "," + std::to_string(height_px) +
       " font 'Helvetica,14' background rgb 'white'\n";
  // Okabe & Ito's colour-blind-safe colours, without their yellow (1.1:1
  // against white); gnuplot's default line type 5 is that yellow.
  t += kOkabeItoLinetypes;
  t += "set output " + gnuplot_quote(svg_name) + "\n";
  t += commands;
  if (!commands.empty() && commands.back() != '\n') t += '\n';
  t += "unset output\n";
  outputs_.push_back(svg_name);
  if (pdf_) {
    const std::string pdf_name = svg_name.substr(0, svg_name.rfind('.')) + ".pdf";
    char size[64];
    std::snprintf(size, sizeof size, "%.2fin,%.2fin", width_px / 96.0, height_px / 96.0);
    t += "set terminal pdfcairo size " + std::string(size) + " font 'Helvetica,10'\n";
    t += "set output " + gnuplot_quote(pdf_name) + "\nreplot\nunset output\n";
    pdf_outputs_.push_back(pdf_name);
  }
  for (std::size_t b = 0; b < blocks_.size(); ++b)
    if (names_block(commands, blocks_[b].name)) plot.blocks.push_back(b);
  order_.emplace_back(true, plots_.size());
  plots_.push_back(std::move(plot));
}

std::string GnuplotScript::text() const {
  std::string out;
  for (const auto& [is_plot, i] : order_) out += is_plot ? plots_[i].text : blocks_[i].text;
  return out;
}

std::vector<std::string> GnuplotScript::split(std::size_t parts) const {
  parts = std::max<std::size_t>(1, std::min(parts, plots_.size()));
  if (plots_.empty()) return {text()};
  // Longest work first, each to the least-loaded part (LPT scheduling): within
  // 4/3 of the best split, and the heavy CDF figures do not pile up in one part.
  constexpr std::size_t kPlotCostBytes = 4096;  // drawing one SVG ~ parsing this much data
  std::vector<std::size_t> cost(plots_.size());
  for (std::size_t p = 0; p < plots_.size(); ++p) {
    cost[p] = kPlotCostBytes + plots_[p].text.size();
    for (std::size_t b : plots_[p].blocks) cost[p] += blocks_[b].text.size();
  }
  std::vector<std::size_t> by_cost(plots_.size());
  for (std::size_t p = 0; p < by_cost.size(); ++p) by_cost[p] = p;
  std::stable_sort(by_cost.begin(), by_cost.end(), [&](std::size_t a, std::size_t b) { return cost[a] > cost[b]; });
  std::vector<std::size_t> load(parts, 0);
  std::vector<std::size_t> part_of(plots_.size());
  for (std::size_t p : by_cost) {
    const auto least = static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    part_of[p] = least;
    load[least] += cost[p];
  }
  std::vector<std::string> out(parts);
  for (std::size_t k = 0; k < parts; ++k) {
    std::vector<bool> needed(blocks_.size(), false);
    for (std::size_t p = 0; p < plots_.size(); ++p)
      if (part_of[p] == k)
        for (std::size_t b : plots_[p].blocks) needed[b] = true;
    for (std::size_t b = 0; b < blocks_.size(); ++b)
      if (needed[b]) out[k] += blocks_[b].text;
    for (std::size_t p = 0; p < plots_.size(); ++p)
      if (part_of[p] == k) out[k] += plots_[p].text;
  }
  return out;
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

// Starts gnuplot on one script in the staging directory, its output and
// messages to `log_path`. Returns the child's pid.
pid_t spawn_gnuplot(const std::filesystem::path& gnuplot, const std::filesystem::path& script_path,
                    const std::filesystem::path& log_path, const std::filesystem::path& workdir) {
  // posix_spawn rather than system(): no shell, so no quoting of paths.
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  // Not the caller's stdin (the console's terminal): a script that pauses
  // for input gets end of file and goes on.
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  // Output names in the script are relative to its directory, so it reruns there by hand.
  const std::string dir_text = workdir.string();
  posix_spawn_file_actions_addchdir_np(&actions, dir_text.c_str());
  const std::string program = gnuplot.string();
  const std::string script_arg = script_path.string();
  char* argv[] = {const_cast<char*>(program.c_str()), const_cast<char*>(script_arg.c_str()), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, program.c_str(), &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) throw DataError("cannot start gnuplot '" + program + "': " + std::strerror(spawned));
  return pid;
}

// Waits for the child; returns its status (a failed wait counts as a crash).
int wait_for(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return -1;
  }
  return status;
}

std::string slurp_log(const std::filesystem::path& path) {
  std::ifstream log(path);
  std::stringstream messages;
  messages << log.rdbuf();
  return messages.str();
}

}  // namespace

void run_gnuplot(const GnuplotScript& script, const std::filesystem::path& dir,
                 const std::filesystem::path& gnuplot, std::size_t jobs) {
  // gnuplot draws into a staging directory; the figures and the script move
  // into `dir` only when every one is complete, so a failed run (disk full,
  // a gnuplot error) leaves no truncated figure that looks like a result.
  const StagingDir staging(std::filesystem::absolute(dir) / (".plots." + std::to_string(::getpid()) + ".tmp"));
  const std::filesystem::path script_path = staging.path() / "plots.gp";
  if (jobs == 0) jobs = std::max(1u, std::thread::hardware_concurrency());
  const std::vector<std::string> parts = script.split(jobs);
  try {
    write_file_atomically(script_path, script.text());
    for (std::size_t k = 0; k < parts.size(); ++k)
      write_file_atomically(staging.path() / ("part" + std::to_string(k) + ".gp"), parts[k]);
  } catch (const OutputFileError& e) {
    throw DataError(std::string("cannot write the plot script: ") + e.what());
  }

  std::vector<pid_t> pids;
  std::string failure;
  for (std::size_t k = 0; k < parts.size(); ++k) {
    const std::string part = "part" + std::to_string(k);
    try {
      pids.push_back(spawn_gnuplot(gnuplot, staging.path() / (part + ".gp"), staging.path() / (part + ".log"),
                                   staging.path()));
    } catch (const DataError& e) {
      failure = e.what();
      break;  // the ones started are still waited for below: no zombie, no writer left in staging
    }
  }
  const std::filesystem::path final_script = dir / "plots.gp";
  std::string messages;
  for (std::size_t k = 0; k < pids.size(); ++k) {
    const int status = wait_for(pids[k]);
    const std::string log = slurp_log(staging.path() / ("part" + std::to_string(k) + ".log"));
    messages += log;
    if (failure.empty() && (status < 0 || !WIFEXITED(status) || WEXITSTATUS(status) != 0)) {
      failure = "gnuplot failed on " + final_script.string() +
                (status >= 0 && WIFSIGNALED(status) ? " (killed by signal " + std::to_string(WTERMSIG(status)) + ")"
                                                    : std::string()) +
                ": " + log;
    }
  }
  if (!failure.empty()) throw DataError(failure);
  for (const auto& name : script.outputs()) {
    if (!complete_svg(staging.path() / name)) {
      throw DataError("gnuplot wrote no complete " + (dir / name).string() + " (disk full?): " + messages);
    }
  }
  for (const auto& name : script.pdf_outputs()) {
    if (!complete_pdf(staging.path() / name)) {
      throw DataError("gnuplot wrote no complete " + (dir / name).string() + " (disk full, or no pdfcairo "
                      "terminal in this gnuplot?): " + messages);
    }
  }
  for (const auto& name : script.outputs()) std::filesystem::rename(staging.path() / name, dir / name);
  for (const auto& name : script.pdf_outputs()) std::filesystem::rename(staging.path() / name, dir / name);
  std::filesystem::rename(script_path, final_script);
}

}  // namespace hapticlab::analysis
