#include "console/console_results.h"

#include <cctype>
#include <exception>
#include <stdexcept>

#include "analysis/report/gnuplot.h"
#include "analysis/report/report.h"
#include "analysis/study/metrics_csv.h"
#include "analysis/study/study_analysis.h"

namespace hapticlab::console {

ConsoleResults::ConsoleResults(std::filesystem::path db, std::filesystem::path out_dir)
    : db_(std::move(db)), out_dir_(std::move(out_dir)) {}

ConsoleResults::~ConsoleResults() {
  if (thread_.joinable()) thread_.join();
}

void ConsoleResults::start(bool plots) {
  std::lock_guard lock(mutex_);
  if (state_ == "running") throw std::invalid_argument("an analysis is running; wait for it");
  if (thread_.joinable()) thread_.join();
  state_ = "running";
  message_.clear();
  thread_ = std::thread(&ConsoleResults::run, this, plots);
}

void ConsoleResults::run(bool plots) {
  std::string state = "done", message;
  try {
    analysis::AnalysisOptions options;  // analyze's defaults
    options.ks = false;  // the bootstrap takes minutes; `hapticlab analyze` has it
    if (!plots) options.cdf_points = 0;
    options.validate();
    analysis::ReportOptions report;
    report.plots = plots;
    if (plots) analysis::find_gnuplot();
    const analysis::StudyAnalysis a = analysis::analyze_study_file(db_, options);
    std::filesystem::create_directories(out_dir_);
    analysis::write_metrics_csv(a, out_dir_ / "metrics.csv");
    const analysis::ReportFiles files = analysis::write_report(a, out_dir_, report);
    message = std::to_string(a.trials.size()) + " trials analysed; " + std::to_string(files.figures.size()) +
              " figures (KS bootstrap: run `hapticlab analyze`)";
  } catch (const std::exception& e) {
    state = "failed";
    message = e.what();
  }
  std::lock_guard lock(mutex_);
  state_ = state;
  message_ = message;
}

nlohmann::json ConsoleResults::status() const {
  std::lock_guard lock(mutex_);
  nlohmann::json files = nlohmann::json::array();
  if (state_ != "running")
    for (const char* name : {"report.html", "report.md", "metrics.csv"})
      if (std::filesystem::is_regular_file(out_dir_ / name)) files.push_back(name);
  return {{"state", state_}, {"message", message_}, {"files", files}, {"folder", out_dir_.string()}};
}

std::optional<std::filesystem::path> ConsoleResults::file(const std::string& name) const {
  // NAME or figures/NAME, NAME of letters, digits, '_', '-', '.', not
  // starting with '.' and without "..".
  const std::string base = name.starts_with("figures/") ? name.substr(8) : name;
  if (base.empty() || base.front() == '.' || name.find("..") != std::string::npos) return std::nullopt;
  for (const char c : base)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.') return std::nullopt;
  std::error_code ec;
  const std::filesystem::path root = std::filesystem::weakly_canonical(out_dir_, ec);
  const std::filesystem::path p = std::filesystem::weakly_canonical(out_dir_ / name, ec);
  if (ec || !std::filesystem::is_regular_file(p)) return std::nullopt;
  const auto rel = p.lexically_relative(root);
  if (rel.empty() || *rel.begin() == "..") return std::nullopt;  // a link that leads out
  return p;
}

}  // namespace hapticlab::console
