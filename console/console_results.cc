#include "console/console_results.h"

#include <exception>
#include <fstream>
#include <stdexcept>

#include "analysis/report/gnuplot.h"
#include "analysis/report/report.h"
#include "analysis/study/metrics_csv.h"
#include "analysis/study/study_analysis.h"
#include "console/served_file.h"
#include "core/common/output_file.h"
#include "db/export_csv.h"
#include "db/study_db.h"

namespace hapticlab::console {
namespace {

// Beside the files a job made: the identity of the database they came from.
constexpr const char* kReportStamp = "made-from.txt";
constexpr const char* kExportStamp = "exports/made-from.txt";

// Complete or absent (output_file.h): a stamp cut short by a full disk
// would name no database, or another one.
void write_stamp(const std::filesystem::path& path, const std::string& identity) {
  write_file_atomically(path, identity);
}

}  // namespace

std::string ConsoleResults::database_identity() const {
  try {
    db::OpenOptions o;
    o.read_only = true;
    o.integrity = db::OpenOptions::Integrity::kSkip;
    db::StudyDb db(db_, o);
    const std::vector<db::StudyRow> studies = db.studies();
    if (studies.empty()) return "";
    const db::StudyRow& s = studies.front();
    return "study '" + s.name + "' created " + s.created_utc + ", protocol SHA-256 " + s.protocol_sha256;
  } catch (const std::exception&) {
    return "";
  }
}

std::string ConsoleResults::stamp_of(const std::string& name) const {
  std::ifstream in(out_dir_ / (name.starts_with("exports/") ? kExportStamp : kReportStamp));
  std::string stamp;
  std::getline(in, stamp);
  return stamp;
}

ConsoleResults::ConsoleResults(std::filesystem::path db, std::filesystem::path out_dir)
    : db_(std::move(db)), out_dir_(std::move(out_dir)) {}

ConsoleResults::~ConsoleResults() {
  if (thread_.joinable()) thread_.join();
}

void ConsoleResults::begin(const char* job) {
  if (state_ == "running") throw std::invalid_argument("the " + job_ + " is running; wait for it");
  if (thread_.joinable()) thread_.join();
  job_ = job;
  state_ = "running";
  message_.clear();
}

void ConsoleResults::finish(std::string state, std::string message) {
  std::lock_guard lock(mutex_);
  state_ = std::move(state);
  message_ = std::move(message);
}

void ConsoleResults::start(bool plots) {
  std::lock_guard lock(mutex_);
  begin("analysis");
  thread_ = std::thread(&ConsoleResults::run, this, plots);
}

void ConsoleResults::start_export(const std::string& participant, std::uint64_t every, bool gzip) {
  if (every < 1 || every > 1000000) throw std::invalid_argument("every: " + std::to_string(every) + ", must be 1..1000000");
  std::lock_guard lock(mutex_);
  begin("export");
  exported_.clear();
  thread_ = std::thread(&ConsoleResults::run_export, this, participant, every, gzip);
}

void ConsoleResults::run_export(std::string participant, std::uint64_t every, bool gzip) {
  std::string state = "done", message;
  std::vector<std::string> names;
  try {
    // As `hapticlab export`: read-only, no recovery (a session may be
    // running a trial right now), the full integrity check.
    db::OpenOptions options;
    options.read_only = true;
    options.recover = false;
    options.integrity = db::OpenOptions::Integrity::kFull;
    db::StudyDb db(db_, options);
    const std::vector<db::StudyRow> studies = db.studies();
    if (studies.empty()) throw std::runtime_error(db_.string() + " holds no study");
    const std::string identity = database_identity();
    db::ExportSelection selection;
    selection.one_file = true;
    selection.gzip = gzip;
    selection.every = every;
    if (!participant.empty()) selection.participants.insert(participant);
    const std::filesystem::path dir = out_dir_ / "exports";
    std::filesystem::remove_all(dir);  // an older export's files must not pass for this one's
    std::vector<db::BadChunk> bad;
    const auto files = db::export_study_csv(db, studies.front().id, dir, &bad, selection);
    write_stamp(out_dir_ / kExportStamp, identity);
    for (const auto& f : files) names.push_back("exports/" + f.filename().string());
    message = std::to_string(files.size()) + " files" + (participant.empty() ? "" : " (" + participant + ")") +
              (every > 1 ? ", every " + std::to_string(every) + "th update" : "");
    if (!bad.empty()) {
      std::uint64_t updates = 0;
      for (const db::BadChunk& c : bad) updates += c.count;
      message += "; " + std::to_string(bad.size()) + " damaged sample chunk(s) (" + std::to_string(updates) +
                 " updates) left out: `hapticlab study check` lists them";
      state = "incomplete";  // as `hapticlab export` exits 1: the files are not the whole study
    }
  } catch (const std::exception& e) {
    state = "failed";
    message = e.what();
  }
  {
    std::lock_guard lock(mutex_);
    exported_ = names;
  }
  finish(state, message);
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
    const std::string identity = database_identity();
    std::filesystem::remove(out_dir_ / kReportStamp);  // the old report is not this one's while it is made
    const analysis::StudyAnalysis a = analysis::analyze_study_file(db_, options);
    std::filesystem::create_directories(out_dir_);
    analysis::write_metrics_csv(a, out_dir_ / "metrics.csv");
    const analysis::ReportFiles files = analysis::write_report(a, out_dir_, report);
    write_stamp(out_dir_ / kReportStamp, identity);
    message = std::to_string(a.trials.size()) + " trials analysed; " + std::to_string(files.figures.size()) +
              " figures (KS bootstrap: run `hapticlab analyze`)";
    if (a.counts.damaged_chunks > 0) {
      // As `hapticlab analyze` exits 1: the results are not the whole study's.
      state = "incomplete";
      message += "; " + std::to_string(a.counts.damaged_chunks) +
                 " damaged sample chunk(s) left out, their trials without measures: `hapticlab study check` lists "
                 "them";
    }
    for (const std::string& w : a.session_conditions.warnings) message += "; warning: " + w;
  } catch (const std::exception& e) {
    state = "failed";
    message = e.what();
  }
  finish(state, message);
}

nlohmann::json ConsoleResults::status() const {
  const std::string identity = database_identity();
  std::lock_guard lock(mutex_);
  nlohmann::json files = nlohmann::json::array();
  std::string stale;
  if (state_ != "running") {
    const bool report_current = !identity.empty() && stamp_of("report.html") == identity;
    for (const char* name : {"report.html", "report.md", "metrics.csv"})
      if (std::filesystem::is_regular_file(out_dir_ / name)) {
        if (report_current) files.push_back(name);
        else stale = "the analysis in " + out_dir_.string() + " was made from another database (re-created since); "
                     "run it again";
      }
    const bool export_current = !identity.empty() && stamp_of("exports/x") == identity;
    for (const std::string& name : exported_)
      if (export_current && std::filesystem::is_regular_file(out_dir_ / name)) files.push_back(name);
  }
  nlohmann::json j = {{"job", job_}, {"state", state_}, {"message", message_}, {"files", files},
                      {"folder", out_dir_.string()}};
  if (!stale.empty()) j["stale"] = stale;
  return j;
}

std::optional<std::filesystem::path> ConsoleResults::file(const std::string& name) const {
  std::optional<std::filesystem::path> path = served_file(out_dir_, name);
  if (path) {
    const std::string identity = database_identity();
    if (identity.empty() || stamp_of(name) != identity)
      throw std::invalid_argument(name + ": made from another database than " + db_.string() +
                                  " holds now (re-created since); run the analysis or export again");
  }
  return path;
}

}  // namespace hapticlab::console
