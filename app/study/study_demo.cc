#include "app/study/study_demo.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/common/build_info.h"
#include "analysis/study/group_design.h"
#include "analysis/study/headline_format.h"
#include "analysis/report/gnuplot.h"
#include "analysis/report/report.h"
#include "analysis/study/metrics_csv.h"
#include "analysis/study/study_analysis.h"
#include "app/cli/data_paths.h"
#include "app/cli/interrupt_flag.h"
#include "app/cli/population_option.h"
#include "app/cli/progress_line.h"
#include "core/common/input_file.h"
#include "core/common/sha256.h"
#include "db/study_db.h"
#include "sessions/session_runner.h"
#include "sessions/study_progress.h"
#include "sessions/study_setup.h"
#include "planning/plan_folder.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

struct DemoOptions {
  std::string out = "demo-output";
  bool quick = false;
  std::string protocol;  // empty: the shipped thesis protocol
  bool plots = true;
  std::string population;  // --population (app/cli/population_option.h)
};

std::string read_text(const fs::path& path) {
  return read_text_file(path, kMaxJsonFileBytes, "protocol file");  // the cap the protocol reader applies
}

// Creates the study, or checks that the one already in `db_path` came from
// the same protocol file (then the run resumes it).
void create_or_resume(const fs::path& db_path, const fs::path& protocol, ProgressLine& line) {
  const bool existed = fs::exists(db_path);
  db::StudyDb db(db_path);
  const auto studies = db.studies();
  if (!studies.empty()) {
    const std::string hash = sha256_hex(read_text(protocol));
    if (studies.front().protocol_sha256 != hash)
      throw std::runtime_error(db_path.string() + " holds a study from another protocol (" + studies.front().name +
                               "); choose another --out directory or delete it");
    line.print("Resuming the study in " + db_path.string());
    return;
  }
  if (existed) line.print("Creating the study in the empty database " + db_path.string());
  const sessions::CreatedStudy created = sessions::create_study(db, protocol, software_version());
  line.print("1. Study designed and block-randomized: " + std::to_string(created.participants) +
             " simulated surgeons, " + std::to_string(created.trials) + " trials -> " + db_path.string());
}

// When `code`'s next sitting of a group design is due (simulated time: the
// demo starts each sitting then); nullopt when it is due now.
std::optional<double> next_due_unix_s(const fs::path& db_path, const std::string& code) {
  db::OpenOptions open;
  open.integrity = db::OpenOptions::Integrity::kSkip;
  db::StudyDb db(db_path, open);
  for (const auto& p : sessions::study_progress(db).participants)
    if (p.code == code && p.sitting) return p.sitting->due_unix_s;
  return std::nullopt;
}

// 3. and 4.: the analysis of the study just run, its report and where the
// files are. A between-group design gets its transfer analysis
// (analysis/study/group_design.h) instead of the within-participant tables.
void analyse_and_report(const fs::path& db_path, const fs::path& out, bool plots, ProgressLine& line) {
  char text[256];
  analysis::AnalysisOptions analysis_options;
  const analysis::StudyAnalysis result = analysis::analyze_study_file(db_path, analysis_options);
  const fs::path metrics = out / "metrics.csv";
  analysis::write_metrics_csv(result, metrics);
  if (result.group_design) {
    const analysis::GroupDesignFiles files = analysis::write_group_design(
        analysis::analyze_group_design(result), out, plots ? analysis::find_gnuplot() : fs::path());
    line.print("3. Analysis: a between-group design, " + std::to_string(result.counts.analysed) +
               " trials analysed: transfer analysis and learning curves (the within-participant tables do not apply)");
    std::printf("4. Results in %s:\n   database  %s\n   metrics   %s\n   transfer  %s   (and %zu more files)\n",
                out.c_str(), db_path.c_str(), metrics.c_str(), files.markdown.c_str(), files.written.size() - 1);
    return;
  }
  analysis::ReportOptions report_options;
  report_options.plots = plots;
  const analysis::ReportFiles report = analysis::write_report(result, out, report_options);
  std::snprintf(text, sizeof text, "3. Analysis: %zu trials analysed, %zu aborted left out, %zu figures",
                result.counts.analysed, result.counts.aborted_excluded, report.figures.size());
  line.print(text);

  std::printf("\n%s\n", analysis::format_headline_tables(result).c_str());
  std::printf("4. Results in %s:\n", out.c_str());
  std::printf("   database  %s   (hapticlab study show --db %s; schema: db/README.md)\n", db_path.c_str(),
              db_path.c_str());
  std::printf("   metrics   %s   (one row per trial and instrument)\n", metrics.c_str());
  std::printf("   report    %s   (open in a browser; Markdown: %s)\n", report.html.c_str(), report.markdown.c_str());
}

// The participant's sessions: one, or in a group design every sitting left
// (one per session), each started on simulated time when it is due.
sessions::SessionResult run_sittings(const fs::path& db_path, const std::string& code,
                                     sessions::SessionOptions& options, std::uint64_t& updates) {
  sessions::SessionResult r = sessions::run_session(db_path, options);
  while (!r.stopped_by_operator && !r.device_fault && r.trials_left > 0 && r.trials_run > 0) {
    updates += r.samples_logged;
    options.now_unix_s = next_due_unix_s(db_path, code);
    r = sessions::run_session(db_path, options);
  }
  updates += r.samples_logged;
  return r;
}

// Where the study stands: the bar runs over every scheduled trial.
struct DemoStanding {
  std::vector<std::string> codes;
  int total = 0, done_before = 0;
};

DemoStanding demo_standing(const fs::path& db_path) {
  DemoStanding s;
  db::OpenOptions open;
  open.integrity = db::OpenOptions::Integrity::kQuick;
  db::StudyDb db(db_path, open);
  const sessions::StudyProgress progress = sessions::study_progress(db);
  for (const auto& p : progress.participants) {
    s.codes.push_back(p.code);
    s.total += p.scheduled;
    s.done_before += p.complete;
  }
  return s;
}

// What the demo's sessions did this run.
struct DemoSessions {
  int done = 0, timed_out = 0;
  std::uint64_t updates = 0;
  bool interrupted = false;
};

double demo_seconds_since(std::chrono::steady_clock::time_point started) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
}

// Every participant's sittings on the virtual clock, with the progress bar.
DemoSessions run_demo_sessions(const fs::path& db_path, const DemoStanding& standing, const ChosenPopulation& population,
                               ProgressLine& line, std::chrono::steady_clock::time_point started,
                               const InterruptFlag& interrupt) {
  DemoSessions s;
  s.done = standing.done_before;
  const int total = standing.total;
  const double run_started_s = demo_seconds_since(started);
  for (const std::string& code : standing.codes) {
    sessions::SessionOptions options;
    options.participant = code;
    options.population = population.point;
    options.clock = ClockKind::kVirtual;
    options.stop = &interrupt.flag();
    options.on_progress = [&](const sessions::SessionProgress& p) {
      if (p.phase != sessions::SessionProgress::Phase::kTrialFinished) return;
      if (p.status == db::TrialStatus::kComplete) ++s.done;
      else if (p.abort_reason.starts_with("time limit")) ++s.timed_out;
      const int finished_here = s.done - standing.done_before;
      std::optional<double> eta;
      if (finished_here > 0)
        eta = (demo_seconds_since(started) - run_started_s) / finished_here * (total - s.done - s.timed_out);
      line.update(static_cast<double>(s.done + s.timed_out) / total,
                  "2. sessions: " + code + " " + p.task + " trial " + std::to_string(p.trial_number) + "/" +
                      std::to_string(p.trial_count),
                  demo_seconds_since(started), eta);
    };
    const sessions::SessionResult r = run_sittings(db_path, code, options, s.updates);
    if (r.stopped_by_operator) {
      s.interrupted = true;
      return s;
    }
    if (r.device_fault) throw std::runtime_error(code + ": " + r.device_fault_reason);
  }
  return s;
}

int run(const DemoOptions& opt) {
  const auto started = std::chrono::steady_clock::now();
  const fs::path out(opt.out);
  planning::prepare_plan_folder(out);
  const fs::path protocol = opt.protocol.empty()
                                ? default_protocols_dir() / (opt.quick ? "thesis_quick.json" : "thesis_as_run.json")
                                : fs::path(opt.protocol);
  if (!fs::exists(protocol)) throw std::runtime_error(protocol.string() + ": protocol file not found");
  const fs::path db_path = out / "study.db";

  const ChosenPopulation population = choose_population(opt.population);
  ProgressLine line;
  line.print("HapticLab demo: the thesis study (" + protocol.string() +
             ") on the simulated rig, virtual clock; simulated surgeons from the " + population.describe);
  create_or_resume(db_path, protocol, line);
  const DemoStanding standing = demo_standing(db_path);
  if (standing.done_before > 0) line.print("   " + std::to_string(standing.done_before) + " of " +
                                           std::to_string(standing.total) + " trials already complete; continuing");

  InterruptFlag interrupt;
  const DemoSessions s = run_demo_sessions(db_path, standing, population, line, started, interrupt);
  line.finish();
  if (s.interrupted) {
    std::fprintf(stderr, "hapticlab demo: interrupted; %d of %d trials are safely stored in %s. Run the same "
                         "command again to resume.\n", s.done, standing.total, db_path.c_str());
    return 130;
  }
  char text[256];
  std::snprintf(text, sizeof text, "2. Sessions done: %d of %d trials complete%s, %.1f million loop updates logged "
                "this run, database %.0f MB",
                s.done, standing.total, s.timed_out > 0 ? (", " + std::to_string(s.timed_out) + " timed out").c_str() : "",
                static_cast<double>(s.updates) / 1e6, static_cast<double>(fs::file_size(db_path)) / 1e6);
  line.print(text);

  analyse_and_report(db_path, out, opt.plots, line);
  std::printf("Done in %s.\n", format_duration(demo_seconds_since(started)).c_str());
  return 0;
}

}  // namespace

void add_study_demo_command(CLI::App& app) {
  auto opt = std::make_shared<DemoOptions>();
  CLI::App* cmd = app.add_subcommand(
      "demo",
      "Run the thesis study end to end on the simulated rig: design and block-randomize it (Table 3.3, "
      "3 dissection and 9 clip repetitions), run every simulated surgeon's sessions with the virtual clock "
      "logging every sample into SQLite, analyze, and write the metrics CSV and the HTML/Markdown report. "
      "Interrupted (Ctrl-C, kill), it resumes where it stopped when run again with the same --out.");
  cmd->add_option("--out", opt->out, "Directory for study.db, metrics.csv, report.html, report.md, figures/")
      ->capture_default_str();
  CLI::Option* quick =
      cmd->add_flag("--quick", opt->quick, "A smaller run (2 repetitions per task) for tests and a first look");
  // Refused rather than ignored: --quick picks the smaller shipped protocol.
  cmd->add_option("--protocol", opt->protocol,
                  "Run another protocol file instead of the shipped thesis study")
      ->check(CLI::ExistingFile)
      ->excludes(quick);
  cmd->add_flag("--no-plots", [opt](std::int64_t) { opt->plots = false; },
                "Tables only (no gnuplot needed)");
  add_population_option(cmd, opt->population);
  cmd->callback([opt] {
    const int status = run(*opt);
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace hapticlab::app
