#include "app/plan/plan_command.h"
#include "app/plan/plan_power_options.h"
#include "app/plan/plan_transfer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "analysis/report/gnuplot.h"
#include "app/cli/cli_checks.h"
#include "app/cli/interrupt_flag.h"
#include "app/cli/population_option.h"
#include "app/cli/progress_line.h"
#include "core/common/csv_format.h"
#include "core/settings/settings_json.h"
#include "core/common/output_file.h"
#include "app/cli/data_paths.h"
#include "app/cli/option_shapes.h"
#include "planning/calibration.h"
#include "planning/change_summary.h"
#include "planning/comparison_report.h"
#include "planning/plan_design.h"
#include "planning/plan_inputs.h"
#include "planning/plan_lock.h"
#include "planning/plan_runner.h"
#include "planning/population_fit.h"
#include "planning/power.h"
#include "planning/power_store.h"
#include "protocols/protocol_json.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;



// The --out folder, made now and proven writable, before anything is
// simulated: a folder that cannot take the results is found in a second,
// not after the whole simulation.
void prepare_out_folder(const fs::path& out) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec)
    throw std::runtime_error("--out '" + out.string() + "': cannot make the folder (" + ec.message() +
                             "); nothing was simulated");
  const fs::path probe = out / (".hapticlab-write-check-" + std::to_string(::getpid()));
  {
    std::ofstream f(probe);
    f << "x";
    f.flush();
    if (!f) {
      const std::string why = std::strerror(errno);
      fs::remove(probe, ec);
      throw std::runtime_error("--out '" + out.string() + "': cannot write in the folder (" + why +
                               "); nothing was simulated");
    }
  }
  fs::remove(probe, ec);
}

void write_power_csv(const fs::path& path, const std::vector<planning::PowerRow>& rows) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    // tests: studies (pairwise) or participants' Table 3.4 tests (participant).
    // wilson_*: the simulation's sampling only; model_*: with the fitted
    // population's uncertainty (empty without it).
    out << "participants,method,task,setting,measure,tests,significant,rate,wilson_low,wilson_high,model_low,"
           "model_high\n";
    for (const auto& r : rows) {
      out << r.participants << ',' << r.method << ',' << csv_text(r.task) << ',' << csv_text(r.setting) << ','
          << r.measure << ',' << r.tests << ',' << r.significant << ',' << format_number(r.rate) << ','
          << format_number(r.wilson_low) << ',' << format_number(r.wilson_high) << ','
          << (std::isfinite(r.model_low) ? format_number(r.model_low) : "") << ','
          << (std::isfinite(r.model_high) ? format_number(r.model_high) : "") << '\n';
    }
    out.flush();
    if (!out) throw std::runtime_error(tmp.string() + ": cannot write (disk full?)");
  }
  fs::rename(tmp, path);
}

// One figure per task: power against the number of participants, one line
// per setting, with Wilson 95 % intervals as error bars.
std::vector<std::string> draw_power(const fs::path& out, const std::vector<planning::PowerRow>& rows,
                                    const std::string& measure) {
  analysis::GnuplotScript script;
  std::vector<std::string> tasks;
  for (const auto& r : rows)
    if (std::find(tasks.begin(), tasks.end(), r.task) == tasks.end()) tasks.push_back(r.task);
  for (const std::string& task : tasks) {
    std::vector<std::string> settings;
    std::ostringstream data;
    for (const auto& r : rows)
      if (r.method == "pairwise" && r.task == task && r.measure == measure &&
          std::find(settings.begin(), settings.end(), r.setting) == settings.end())
        settings.push_back(r.setting);
    if (settings.empty()) continue;
    for (const std::string& s : settings) {
      for (const auto& r : rows)
        if (r.method == "pairwise" && r.task == task && r.measure == measure && r.setting == s)
          data << r.participants << ' ' << 100.0 * r.rate << ' ' << 100.0 * r.wilson_low << ' '
               << 100.0 * r.wilson_high << '\n';
      data << "\n\n";
    }
    std::string block = "power_";
    for (char c : task) block += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
    script.add_datablock(block, data.str());
    std::string plot = "set title " + analysis::gnuplot_quote(task + ": " + measure + ", each setting against the control") +
                       "\nset xlabel 'participants'\nset ylabel 'studies significant [%]'\nset yrange [0:100]\n"
                       "set key outside right\nset grid\nplot ";
    for (std::size_t i = 0; i < settings.size(); ++i) {
      plot += (i ? ", " : "") + std::string("$") + block + " index " + std::to_string(i) +
              " using 1:2:3:4 with yerrorlines lw 2 title " + analysis::gnuplot_quote(settings[i]);
    }
    script.add_plot(block + ".svg", plot, 900, 500);
  }
  if (script.outputs().empty()) return {};
  analysis::run_gnuplot(script, out, analysis::find_gnuplot());
  return script.outputs();
}

// The design check (planning/plan_design.h), its notes printed on stderr.
planning::PlanDesign checked_design(const protocols::Protocol& protocol, const std::string& protocol_path,
                                    const std::vector<int>& counts, std::uint64_t seed,
                                    const planning::SimulatedStudyOptions& sim) {
  planning::PlanDesign design = planning::check_plan_design(protocol, protocol_path, counts, seed, sim);
  for (const std::string& note : design.notes) std::fprintf(stderr, "note: %s\n", note.c_str());
  return design;
}

// What a finished plan writes and prints: power.csv, the comparison of each
// setting's predicted change, the figures and the tables. A plan run on one
// machine and the same plan merged from shards (plan merge) give the same
// files byte for byte.
struct PlanResults {
  const protocols::Protocol& protocol;
  const planning::PlanInputs& inputs;
  const planning::PlanDesign& design;
  std::vector<planning::StudyOutcome> outcomes;  // every study of the plan
  fs::path out;
  std::string measure;
  bool plots = true;
  bool json = false;
  // This run's work, for the summary line and --json.
  std::string did;  // "12 studies simulated in 3.1 s (...)", or the merge's
  double seconds_this_run = 0.0;
  std::size_t studies_this_run = 0;
  std::string population;  // whom the studies simulated, in words
};
int write_plan_results(const PlanResults& p);

std::vector<int> plan_counts(const PlanPowerOptions& o, const protocols::Protocol& protocol) {
  std::vector<int> counts = o.participants;
  if (counts.empty()) counts.push_back(static_cast<int>(protocol.participants.size()));
  std::sort(counts.begin(), counts.end());
  counts.erase(std::unique(counts.begin(), counts.end()), counts.end());
  return counts;
}

planning::SimulatedStudyOptions plan_simulation(double rate_Hz, double max_trial_s) {
  planning::SimulatedStudyOptions sim;
  sim.rate_Hz = rate_Hz;
  sim.max_trial_s = max_trial_s;
  return sim;
}

// What a plan records of its population: the file's SHA-256, or the
// unfitted model's version.
std::string population_key(const ChosenPopulation& p) {
  return p.file ? "sha256 " + p.file->sha256 : "unfitted model " + std::to_string(kParticipantModelVersion);
}

void check_shard_count(const PlanPowerOptions& o, std::size_t plan_size) {
  if (static_cast<std::size_t>(o.shards) > plan_size)
    throw std::runtime_error("--shard " + std::to_string(o.shard) + "/" + std::to_string(o.shards) + ": the plan has " +
                             std::to_string(plan_size) + " studies (--participants x --studies), so at most " +
                             std::to_string(plan_size) + " shards, each with a study");
}

int run_plan_power(const PlanPowerOptions& o) {
  const protocols::Protocol protocol = protocols::load_protocol_file(o.protocol);
  if (const std::optional<int> status = run_if_transfer_design(protocol, o)) return *status;
  const std::string protocol_text = protocols::read_protocol_text(o.protocol);
  const ChosenPopulation population = choose_population(o.population);
  const bool has_draws = population.file && !population.file->draws.empty();
  if (o.model_uncertainty == "on" && !has_draws)
    throw std::runtime_error("--model-uncertainty on: " + population.describe +
                             " has no posterior draws to draw from; use a fitted population file");
  const bool model_uncertainty = o.model_uncertainty == "on" || (o.model_uncertainty == "auto" && has_draws);
  planning::SimulatedStudyOptions sim = plan_simulation(o.rate_Hz, o.max_trial_s);
  sim.population = population.point;
  const std::vector<int> counts = plan_counts(o, protocol);
  const planning::PlanDesign design = checked_design(protocol, o.protocol, counts, o.seed, sim);
  planning::PlanInputs inputs = planning::plan_inputs(protocol, o.protocol, protocol_text, o.seed, counts, o.studies, sim);
  inputs.population = population_key(population);
  inputs.model_uncertainty = model_uncertainty;
  inputs.shard = o.shard;
  inputs.shards = o.shards;
  const std::size_t plan_size = inputs.studies_of_plan().size();
  check_shard_count(o, plan_size);
  if (o.plots) (void)analysis::find_gnuplot();

  prepare_out_folder(o.out);
  // One run per folder; then the stored plan must be this one, every row checked.
  const planning::PlanLock lock = planning::PlanLock::acquire(o.out);
  planning::PowerStore store(fs::path(o.out) / "plan_power.db", inputs, protocol);
  const std::set<std::pair<int, int>> done = store.done();
  std::vector<std::pair<int, int>> todo;
  const std::vector<std::pair<int, int>> mine = inputs.studies_of_shard();
  for (const auto& study : mine)
    if (!done.count(study)) todo.push_back(study);
  const std::size_t total = mine.size();
  const std::size_t already = total - todo.size();

  ProgressLine line(o.json ? stderr : stdout);
  // Default: two studies per core. Each study's haptic loop runs on its own
  // thread while the study's thread sleeps between draining its samples, so
  // one study per core leaves the cores partly idle (4 thesis-sized studies
  // on 2 cores: 12.5 s with 2 jobs, 10.5 s with 4).
  const std::size_t jobs = std::min<std::size_t>(
      o.jobs > 0 ? o.jobs : 2 * std::max(1u, std::thread::hardware_concurrency()),
      std::max<std::size_t>(1, todo.size()));
  if (already > 0) line.print(std::to_string(already) + " of " + std::to_string(total) + " studies already in " +
                              (fs::path(o.out) / "plan_power.db").string() + "; continuing");
  line.print("simulating " + std::to_string(todo.size()) + " studies of " + protocol.study +
             (o.shards > 1 ? " (shard " + std::to_string(o.shard) + "/" + std::to_string(o.shards) + " of the plan's " +
                                 std::to_string(plan_size) + ")"
                           : std::string()) +
             " on " + std::to_string(jobs) + " thread(s), no samples stored; simulated participants from the " +
             population.describe +
             (model_uncertainty ? ", each study's population drawn from its posterior (model uncertainty on)"
                                : ", its point estimate (model uncertainty off)"));

  InterruptFlag interrupt;
  planning::PlanRunOptions run;
  run.seed = o.seed;
  run.sim = sim;
  if (model_uncertainty) run.draws = population.file->draws;
  run.jobs = jobs;
  run.interrupted = [&] { return interrupt.raised(); };
  run.on_progress = [&](std::size_t stored, double elapsed_s) {
    std::optional<double> eta;
    if (stored > 0) eta = elapsed_s / static_cast<double>(stored) * static_cast<double>(todo.size() - stored);
    line.update(static_cast<double>(already + stored) / static_cast<double>(total),
                std::to_string(already + stored) + "/" + std::to_string(total) + " studies" +
                    (interrupt.raised() ? " (stopping after the running ones)" : ""),
                elapsed_s, eta);
  };
  planning::PlanRunResult ran;
  try {
    ran = planning::run_plan_studies(protocol, todo, store, run);
  } catch (const planning::PlanStoreFailure& e) {
    line.finish();
    throw std::runtime_error(std::string(e.what()) + "; the " + std::to_string(already + e.stored) +
                             " studies stored before are kept: free space, then run the same command to resume");
  } catch (...) {
    line.finish();
    throw;
  }
  line.finish();
  const std::size_t stored = ran.stored;
  const double elapsed_s = ran.elapsed_s;
  if (interrupt.raised() && already + stored < total) {
    std::fprintf(stderr, "hapticlab plan power: interrupted; %zu of %zu studies are stored in %s. Run the same "
                         "command again to resume.\n", already + stored, total,
                 (fs::path(o.out) / "plan_power.db").c_str());
    return 130;
  }

  char did[160];
  std::snprintf(did, sizeof did, "%zu %s simulated in %.1f s (%.1f million loop updates, none stored)", stored,
                stored == 1 ? "study" : "studies", elapsed_s, static_cast<double>(ran.updates) / 1e6);
  PlanResults results{protocol, inputs, design, store.load(/*complete=*/true), o.out, o.measure, o.plots, o.json,
                      did, elapsed_s, stored, population.describe};
  if (o.shards > 1) {
    // A shard's studies alone are no plan: `plan merge` makes one of all of them.
    const std::string line_out = "shard " + std::to_string(o.shard) + "/" + std::to_string(o.shards) + ": " + did +
                                 "; all " + std::to_string(total) + " of its studies are in " +
                                 (fs::path(o.out) / "plan_power.db").string() +
                                 ". When every shard is done: hapticlab plan merge SHARD_DIR... --out DIR";
    if (o.json) {
      std::printf("%s\n", nlohmann::json{{"shard", o.shard}, {"shards", o.shards}, {"studies", total},
                                         {"studies_this_run", stored}, {"seconds_this_run", elapsed_s},
                                         {"store", (fs::path(o.out) / "plan_power.db").string()}}
                              .dump(2)
                              .c_str());
    } else {
      std::printf("\n%s\n", line_out.c_str());
    }
    return 0;
  }
  return write_plan_results(results);
}

int write_plan_results(const PlanResults& p) {
  const protocols::Protocol& protocol = p.protocol;
  const std::vector<int>& counts = p.inputs.participants;
  const std::set<std::string>& null_settings = p.design.null_settings;
  const std::string& control_name = p.design.control;
  const planning::SimulatedStudyOptions sim = plan_simulation(p.inputs.rate_Hz, p.inputs.max_trial_s);
  struct {
    const fs::path& out;
    const std::string& measure;
    bool plots, json;
    int studies;
  } o{p.out, p.measure, p.plots, p.json, p.inputs.studies};
  std::vector<std::string> setting_order;
  for (const auto& s : protocol.settings) setting_order.push_back(s.settings.name);
  const std::vector<planning::StudyOutcome>& wanted = p.outcomes;
  const bool model_uncertainty = p.inputs.model_uncertainty;
  const std::vector<planning::PowerRow> rows =
      planning::summarize_power(wanted, setting_order, model_uncertainty ? planning::kDrawGroups : 1);
  const std::vector<planning::FalsePositiveRow> fp = planning::false_positive_rates(wanted, null_settings);
  const std::vector<planning::StaircaseSummaryRow> stairs = planning::summarize_staircases(wanted);
  const auto number_or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  const fs::path csv = fs::path(o.out) / "power.csv";
  write_power_csv(csv, rows);
  // Each setting's predicted change against the control beside the power
  // to detect it (issue 35 §4). One variant, named by how the studies drew
  // their populations: the fit's point estimate, or a posterior draw per
  // group of studies (then the power cells carry the model interval).
  const std::vector<planning::ReportVariant> variants = {
      {model_uncertainty ? "with model uncertainty" : "model fixed",
       planning::summarize_changes(wanted, setting_order), rows,
       planning::summarize_timeouts(wanted, setting_order)}};
  planning::ComparisonReportOptions report;
  report.control = control_name;
  report.participants = counts;
  report.settings = setting_order;
  const std::string comparison = planning::comparison_markdown(variants, report);
  const fs::path change_csv = fs::path(o.out) / "predicted_change.csv";
  const fs::path comparison_md = fs::path(o.out) / "comparison.md";
  write_file_atomically(change_csv, planning::comparison_csv(variants, report));
  write_file_atomically(comparison_md, "# " + protocol.study + ": predicted change and power\n\n" + comparison);
  std::vector<std::string> figures;
  if (o.plots) figures = draw_power(o.out, rows, o.measure);

  if (o.json) {
    nlohmann::json j;
    j["studies_per_count"] = o.studies;
    j["participants"] = counts;
    j["seconds_this_run"] = p.seconds_this_run;
    j["studies_this_run"] = p.studies_this_run;
    j["csv"] = csv.string();
    j["figures"] = figures;
    j["population"] = p.population;
    j["model_uncertainty"] = model_uncertainty;
    nlohmann::json list = nlohmann::json::array();
    for (const auto& r : rows) {
      list.push_back({{"participants", r.participants}, {"method", r.method}, {"task", r.task},
                      {"setting", r.setting}, {"measure", r.measure}, {"significant", r.significant},
                      {"tests", r.tests}, {"rate", r.rate}, {"wilson_low", r.wilson_low},
                      {"wilson_high", r.wilson_high}, {"model_low", number_or_null(r.model_low)},
                      {"model_high", number_or_null(r.model_high)}});
    }
    j["rows"] = list;
    j["null_settings"] = null_settings;
    nlohmann::json fps = nlohmann::json::array();
    for (const auto& r : fp)
      fps.push_back({{"participants", r.participants}, {"method", r.method}, {"measure", r.measure},
                     {"studies", r.studies}, {"with_false_positive", r.with_false_positive}, {"rate", r.rate},
                     {"wilson_low", r.wilson_low}, {"wilson_high", r.wilson_high}});
    j["family_wise_false_positives"] = fps;
    nlohmann::json st = nlohmann::json::array();
    for (const auto& r : stairs)
      st.push_back({{"participants", r.participants}, {"studies", r.studies}, {"staircases", r.staircases},
                    {"with_threshold", r.with_threshold}, {"rate", r.rate}, {"wilson_low", r.wilson_low},
                    {"wilson_high", r.wilson_high}, {"mean_threshold", number_or_null(r.mean_threshold)},
                    {"sd_between_participants", number_or_null(r.sd_between_participants)},
                    {"sd_of_study_means", number_or_null(r.sd_of_study_means)}, {"mean_trials", r.mean_trials}});
    j["staircase"] = st;
    nlohmann::json ch = nlohmann::json::array();
    for (const planning::ChangeRow& r : variants.front().changes)
      ch.push_back({{"variant", variants.front().label}, {"participants", r.participants}, {"task", r.task},
                    {"setting", r.setting}, {"measure", r.measure}, {"studies", r.studies}, {"median", r.median},
                    {"low", r.low}, {"high", r.high}});
    j["predicted_change"] = ch;
    nlohmann::json out = nlohmann::json::array();
    for (const planning::TimeoutRow& r : variants.front().timeouts)
      out.push_back({{"variant", variants.front().label}, {"participants", r.participants}, {"task", r.task},
                     {"setting", r.setting}, {"trials", r.trials}, {"timed_out", r.timed_out}, {"rate", r.rate},
                     {"wilson_low", r.wilson_low}, {"wilson_high", r.wilson_high}});
    j["timed_out"] = out;
    j["comparison"] = {{"csv", change_csv.string()}, {"markdown", comparison_md.string()}};
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("\n%s\n", p.did.c_str());
  auto print_table = [&](const std::string& method, const char* title) {
    // A staircase protocol's baseline alone has nothing to compare.
    if (std::none_of(rows.begin(), rows.end(), [&](const planning::PowerRow& r) { return r.method == method; })) return;
    std::printf("\n%s, %s: share of simulated studies in which the setting differs significantly from the "
                "control (Šidák level), Wilson 95 %% interval (simulation only)%s\n", title, o.measure.c_str(),
                model_uncertainty ? " and, after 'model', the 95 % interval with the model's uncertainty" : "");
    const int width = model_uncertainty ? 32 : 16;
    std::printf("%-12s %-32s", "task", "setting");
    for (int n : counts) std::printf("  %*s", width, (std::to_string(n) + " participants").c_str());
    std::printf("\n");
    std::vector<std::pair<std::string, std::string>> lines;
    for (const auto& r : rows)
      if (r.method == method && r.measure == o.measure &&
          std::find(lines.begin(), lines.end(), std::make_pair(r.task, r.setting)) == lines.end())
        lines.push_back({r.task, r.setting});
    for (const auto& [task, setting] : lines) {
      const std::string label = setting + (null_settings.count(setting) ? " (null)" : "");
      std::printf("%-12s %-32s", task.c_str(), label.c_str());
      for (int n : counts) {
        const auto it = std::find_if(rows.begin(), rows.end(), [&, &task = task, &setting = setting](const planning::PowerRow& r) {
          return r.method == method && r.measure == o.measure && r.task == task && r.setting == setting &&
                 r.participants == n;
        });
        char cell[96] = "";
        if (it != rows.end() && std::isfinite(it->model_low))
          std::snprintf(cell, sizeof cell, "%3.0f%% [%2.0f,%3.0f] model [%2.0f,%3.0f]", 100 * it->rate,
                        100 * it->wilson_low, 100 * it->wilson_high, 100 * it->model_low, 100 * it->model_high);
        else if (it != rows.end())
          std::snprintf(cell, sizeof cell, "%3.0f%% [%2.0f,%3.0f]", 100 * it->rate, 100 * it->wilson_low,
                        100 * it->wilson_high);
        std::printf("  %*s", width, cell);
      }
      std::printf("\n");
    }
  };
  print_table("pairwise", "Thesis procedure (pairwise Friedman, repetitions and hands as replicates)");
  print_table("participant_pairwise", "Participant level (one value per participant, sign-flip test)");
  if (!fp.empty()) {
    std::printf("\nFamily-wise false positives: share of studies in which any comparison of a null setting "
                "(a copy of the control) came out significant, %s\n", o.measure.c_str());
    for (const auto& r : fp)
      if (r.measure == o.measure)
        std::printf("  %-22s %3d participants: %5.1f%% [%4.1f, %5.1f] of %d studies (nominal %g%%)\n",
                    r.method.c_str(), r.participants, 100 * r.rate, 100 * r.wilson_low, 100 * r.wilson_high,
                    r.studies, 100 * sim.analysis.alpha);
  }
  if (protocol.staircase) {
    const auto& sp = protocol.staircase->spec;
    std::printf("\nStaircase of %s (%s changed by %g %% from %s): thresholds found, their mean and spread\n",
                sp.field.c_str(), sp.measure.c_str(), 100 * sp.change, sp.baseline.c_str());
    for (const auto& r : stairs)
      std::printf("  %3d participants: %5.1f%% [%4.1f, %5.1f] of %d staircases ended with a threshold; mean %.3g, "
                  "SD %.3g between participants, SD %.3g of a study's mean; %.1f trials each\n",
                  r.participants, 100 * r.rate, 100 * r.wilson_low, 100 * r.wilson_high, r.staircases,
                  r.mean_threshold, r.sd_between_participants, r.sd_of_study_means, r.mean_trials);
  }
  if (std::any_of(rows.begin(), rows.end(), [](const planning::PowerRow& r) { return r.method == "participant"; }))
    std::printf("\nParticipant-level Friedman (Table 3.4) on %s: share of participants' tests significant\n",
                o.measure.c_str());
  for (const auto& r : rows)
    if (r.method == "participant" && r.measure == o.measure)
      std::printf("  %-12s %3d participants: %5.1f%% [%4.1f, %5.1f] of %d tests\n", r.task.c_str(), r.participants,
                  100 * r.rate, 100 * r.wilson_low, 100 * r.wilson_high, r.tests);
  if (!variants.front().changes.empty())
    std::printf("\nPredicted change against %s and the power to detect it, every measure (%s):\n%s",
                control_name.c_str(), comparison_md.c_str(), comparison.c_str());
  std::printf("\nAll measures: %s, %s", csv.c_str(), change_csv.c_str());
  for (const auto& f : figures) std::printf(", %s", (fs::path(o.out) / f).c_str());
  std::printf("\n");
  return 0;
}

struct PlanMergeOptions {
  std::vector<std::string> shards;  // folders of `plan power --shard I/N`
  std::string out;
  std::string protocol;  // default: the file the shards name
  std::string measure = "force_p95_N";
  bool plots = true;
  bool json = false;
};

std::string shard_label(const planning::PlanInputs& p) {
  return std::to_string(p.shard) + "/" + std::to_string(p.shards);
}

// The shards of one plan, checked to be that and all of it, merged into one
// plan folder that says what a one-machine run of the plan says. Nothing in
// the shards' folders is written.
int run_plan_merge(const PlanMergeOptions& o) {
  // An output folder that is one of the inputs would put the merged plan
  // into a shard's store (refused there as another plan, but say why here).
  const fs::path out = fs::weakly_canonical(fs::absolute(o.out));
  std::vector<planning::PlanInputs> plans;
  std::vector<fs::path> dirs;
  for (const std::string& d : o.shards) {
    const fs::path dir = fs::weakly_canonical(fs::absolute(d));
    if (dir == out) throw std::runtime_error("--out '" + o.out + "' is one of the shard folders it merges (" + d +
                                             "): name a folder of its own");
    if (std::find(dirs.begin(), dirs.end(), dir) != dirs.end())
      throw std::runtime_error("shard folder '" + d + "' is named twice");
    const fs::path db = dir / "plan_power.db";
    if (!fs::exists(db))
      throw std::runtime_error(d + ": no plan_power.db: not a folder of `plan power --shard` (or its run never began)");
    planning::PlanInputs p = planning::PowerStore::read_plan(db);
    if (p.shards < 2)
      throw std::runtime_error(d + ": holds a whole plan (" + p.describe() + "), not a shard of one; plan merge "
                               "joins the folders of `plan power --shard I/N`");
    dirs.push_back(dir);
    plans.push_back(std::move(p));
  }
  // One plan: every input the same but the shard, and each shard once.
  const planning::PlanInputs& first = plans.front();
  std::vector<int> holder(static_cast<std::size_t>(first.shards), -1);
  for (std::size_t k = 0; k < plans.size(); ++k) {
    const planning::PlanInputs& p = plans[k];
    std::vector<std::string> differ = planning::plan_differences(first.whole(), p.whole());
    if (p.shards != first.shards)
      differ.push_back("the number of shards (" + std::to_string(first.shards) + " in " + o.shards.front() + ", " +
                       std::to_string(p.shards) + " here)");
    if (!differ.empty()) {
      std::string list;
      for (const std::string& d : differ) list += (list.empty() ? "" : "; ") + d;
      throw std::runtime_error(o.shards[k] + ": a shard of another plan than " + o.shards.front() + " (" +
                               first.describe() + "): " + list + " differ (\"then\" is " + o.shards.front() +
                               ", \"now\" " + o.shards[k] + "); plan merge joins the shards of one plan");
    }
    int& h = holder[static_cast<std::size_t>(p.shard)];
    if (h >= 0)
      throw std::runtime_error("shard " + shard_label(p) + " is in both " + o.shards[static_cast<std::size_t>(h)] +
                               " and " + o.shards[k] + "; name each shard's folder once");
    h = static_cast<int>(k);
  }
  std::string missing;
  for (std::size_t i = 0; i < holder.size(); ++i)
    if (holder[i] < 0) missing += (missing.empty() ? "" : ", ") + std::to_string(i) + "/" + std::to_string(first.shards);
  if (!missing.empty())
    throw std::runtime_error("the plan has " + std::to_string(first.shards) + " shards, and " + missing +
                             (missing.find(',') == std::string::npos ? " is" : " are") +
                             " not among the folders given; run (or name) the missing shard's folder");

  // The protocol the shards were made from, proven the same file and settings.
  const std::string protocol_path = o.protocol.empty() ? first.protocol_file : o.protocol;
  if (!fs::exists(protocol_path))
    throw std::runtime_error("the shards were made from the protocol '" + first.protocol_file + "', which is not at " +
                             protocol_path + " from here: give its path with --protocol");
  const protocols::Protocol protocol = protocols::load_protocol_file(protocol_path);
  const std::string protocol_text = protocols::read_protocol_text(protocol_path);
  const planning::SimulatedStudyOptions sim = plan_simulation(first.rate_Hz, first.max_trial_s);
  planning::PlanInputs whole = planning::plan_inputs(protocol, first.protocol_file, protocol_text, first.seed,
                                                     first.participants, first.studies, sim);
  // The population is the shards' (merging simulates nothing).
  whole.population = first.population;
  whole.model_uncertainty = first.model_uncertainty;
  if (const std::vector<std::string> d = planning::plan_differences(first.whole(), whole); !d.empty()) {
    std::string list;
    for (const std::string& x : d) list += (list.empty() ? "" : "; ") + x;
    throw std::runtime_error(protocol_path + ": not the protocol the shards were made from: " + list +
                             " (\"then\" is the shards', \"now\" this file's)");
  }
  const planning::PlanDesign design = checked_design(protocol, protocol_path, whole.participants, whole.seed, sim);
  if (o.plots) (void)analysis::find_gnuplot();

  // Every shard's rows checked as its own run checks them, complete, while
  // no run of it can add to it.
  std::vector<planning::PlanLock> locks;
  std::map<std::pair<int, int>, planning::StudyOutcome> studies;
  for (std::size_t k = 0; k < plans.size(); ++k) {
    locks.push_back(planning::PlanLock::acquire(dirs[k]));
    planning::PowerStore shard(dirs[k] / "plan_power.db", plans[k], protocol);
    for (planning::StudyOutcome& s : shard.load(/*complete=*/true)) studies[{s.participants, s.index}] = std::move(s);
  }

  prepare_out_folder(o.out);
  const planning::PlanLock lock = planning::PlanLock::acquire(o.out);
  planning::PowerStore merged(fs::path(o.out) / "plan_power.db", whole, protocol);
  const std::set<std::pair<int, int>> done = merged.done();  // merged before: the same studies, checked
  std::size_t added = 0;
  for (const auto& [key, s] : studies) {
    if (done.count(key)) continue;
    try {
      merged.add(s);
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string(e.what()) + "; " + std::to_string(done.size() + added) + " of " +
                               std::to_string(studies.size()) + " studies are in " +
                               (fs::path(o.out) / "plan_power.db").string() +
                               ", the shards are untouched: free space, then run the same merge again");
    }
    ++added;
  }
  char did[200];
  std::snprintf(did, sizeof did, "%zu shards merged: %zu studies (%zu added now, %zu already in %s)", plans.size(),
                studies.size(), added, done.size(), (fs::path(o.out) / "plan_power.db").c_str());
  return write_plan_results({protocol, whole, design, merged.load(/*complete=*/true), o.out, o.measure, o.plots, o.json,
                             did, 0.0, 0, "population " + whole.population});
}

struct PlanCalibrateOptions {
  std::string protocol;
  int participants = 100;
  std::uint64_t seed = 1;
  std::size_t jobs = 0;
  std::string out = "plan-calibrate";
  double rate_Hz = 0.0;  // 0: 1000 Hz, or 250 Hz with --fit
  double max_trial_s = 300.0;
  bool json = false;
  std::string population;  // --population (app/cli/population_option.h)
  bool fit = false;
  int fit_studies = 48;  // as PopulationFitOptions
  std::string command;  // the command line, for the fitted file
};

void write_text_file(const fs::path& path, const std::string& text) {
  try {
    write_file_atomically(path, text);
  } catch (const OutputFileError& e) {
    throw std::runtime_error(std::string(e.what()) + " (disk full?)");
  }
}

// `plan calibrate --fit`: the population fitted to the calibration set
// (planning/population_fit.h). Writes DIR/population.json (only when the fit
// converged), DIR/fit_targets.csv, DIR/fit_parameters.csv and
// DIR/fit_summary.json.
int run_plan_calibrate_fit(const PlanCalibrateOptions& o) {
  const fs::path protocol_path =
      o.protocol.empty() ? default_protocols_dir() / "thesis_as_run.json" : fs::path(o.protocol);
  const protocols::Protocol protocol = protocols::load_protocol_file(protocol_path.string());
  planning::PopulationFitOptions fit;
  fit.studies_per_design_point = o.fit_studies;
  fit.seed = o.seed;
  fit.rate_Hz = o.rate_Hz > 0.0 ? o.rate_Hz : 250.0;
  fit.max_trial_s = o.max_trial_s;
  fit.jobs = o.jobs;
  fit.command = o.command;
  fs::create_directories(o.out);
  ProgressLine line(o.json ? stderr : stdout);
  line.print("fitting the simulated population to the calibration set (docs/simulation.md): " +
             std::to_string(9 * o.fit_studies) + " simulated 3-surgeon studies of " + protocol.study + " at " +
             format_number(fit.rate_Hz) + " Hz, then the posterior on a grid");
  InterruptFlag interrupt;
  const auto started = std::chrono::steady_clock::now();
  std::string stage;
  double stage_started_s = 0.0;
  const planning::PopulationFitResult r = planning::fit_population(
      protocol, fit,
      [&](const std::string& what, int done, int total) {
        const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        if (what != stage) {
          if (!stage.empty()) line.finish();
          stage = what;
          stage_started_s = elapsed_s;
        }
        std::optional<double> eta;
        if (done > 0) eta = (elapsed_s - stage_started_s) / done * (total - done);
        line.update(total > 0 ? static_cast<double>(done) / total : 0.0,
                    what + ": " + std::to_string(done) + "/" + std::to_string(total), elapsed_s, eta);
      },
      [&] { return interrupt.raised(); });
  line.finish();

  // Diagnostics, whatever the outcome.
  std::ostringstream targets;
  targets << "id,source,where,kind,published_value,published_sd,model_mean,model_low95,model_high95,met,note\n";
  for (const auto& d : r.targets) {
    const bool event = d.target.kind == planning::CalibrationTarget::Kind::kEvent;
    targets << d.target.id << ',' << d.target.source << ',' << csv_text(d.target.where) << ','
            << (event ? "event (probability of the published outcome)" : "value") << ','
            << (event ? "" : format_number(d.target.value)) << ',' << (event ? "" : format_number(d.target.sd))
            << ',' << format_number(d.mean) << ',' << format_number(d.low95) << ',' << format_number(d.high95)
            << ',' << (d.met ? "yes" : "no") << ',' << csv_text(d.note) << '\n';
  }
  write_text_file(fs::path(o.out) / "fit_targets.csv", targets.str());
  std::ostringstream parameters;
  parameters << "name,free,prior_low,prior_high,prior_scale,posterior_mean,posterior_sd,low95,high95,why,source\n";
  for (const auto& p : r.file.free)
    parameters << p.name << ",yes," << format_number(p.prior_low) << ',' << format_number(p.prior_high) << ','
               << (p.prior_log ? "log" : "linear") << ',' << format_number(p.mean) << ',' << format_number(p.sd)
               << ',' << format_number(p.low95) << ',' << format_number(p.high95) << ',' << csv_text(p.why) << ','
               << csv_text(p.prior_source) << '\n';
  for (const auto& p : r.file.fixed)
    parameters << p.name << ",no,,,," << format_number(p.value) << ",,,,," << csv_text(p.source) << '\n';
  write_text_file(fs::path(o.out) / "fit_parameters.csv", parameters.str());
  nlohmann::json summary = r.summary;
  summary["converged"] = r.converged;
  summary["problems"] = r.problems;
  summary["notes"] = r.notes;
  write_text_file(fs::path(o.out) / "fit_summary.json", summary.dump(2) + "\n");
  const fs::path population_path = fs::path(o.out) / "population.json";
  if (r.converged) {
    planning::PopulationFile file = r.file;
    write_text_file(population_path, planning::population_file_text(file));
  }

  if (o.json) {
    nlohmann::json j = summary;
    j["population_file"] = r.converged ? nlohmann::json(population_path.string()) : nlohmann::json();
    nlohmann::json t = nlohmann::json::array();
    for (const auto& d : r.targets)
      t.push_back({{"id", d.target.id}, {"mean", d.mean}, {"low95", d.low95}, {"high95", d.high95}, {"met", d.met},
                   {"note", d.note}});
    j["targets"] = t;
    nlohmann::json p = nlohmann::json::array();
    for (const auto& f : r.file.free)
      p.push_back({{"name", f.name}, {"mean", f.mean}, {"sd", f.sd}, {"low95", f.low95}, {"high95", f.high95}});
    j["parameters"] = p;
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("\nFree parameters (posterior mean, SD, 95 %% interval; prior):\n");
    for (const auto& p : r.file.free)
      std::printf("  %-20s %.4g (SD %.2g) [%.4g, %.4g]; prior %s %g..%g\n", p.name.c_str(), p.mean, p.sd, p.low95,
                  p.high95, p.prior_log ? "log-uniform" : "uniform", p.prior_low, p.prior_high);
    std::printf("\nCalibration targets under the fitted population (event: probability that a study of the "
                "source's design has the published outcome; value: the model's value), posterior mean [95 %%]:\n");
    for (const auto& d : r.targets) {
      const bool event = d.target.kind == planning::CalibrationTarget::Kind::kEvent;
      std::printf("  %-28s %s %.3g [%.3g, %.3g]%s  %s\n", d.target.id.c_str(), event ? "P =" : "  ", d.mean, d.low95,
                  d.high95,
                  event ? "" : (" vs " + format_number(d.target.value) + " +- 1.96 x " + format_number(d.target.sd)).c_str(),
                  d.met ? "met" : "MISSED");
    }
    for (const auto& n : r.notes) std::printf("note: %s\n", n.c_str());
    std::printf("\nFit: %.0f s; %s\n", r.summary.value("seconds", 0.0),
                r.converged ? ("population written to " + population_path.string()).c_str()
                            : "did not converge (below)");
    std::printf("Diagnostics: %s, %s, %s\n", (fs::path(o.out) / "fit_targets.csv").c_str(),
                (fs::path(o.out) / "fit_parameters.csv").c_str(), (fs::path(o.out) / "fit_summary.json").c_str());
  }
  if (!r.converged) {
    std::string why;
    for (const auto& p : r.problems) why += "\n  - " + p;
    throw std::runtime_error("the fit did not converge; no population.json was written (diagnostics are in " +
                             o.out + "):" + why);
  }
  return 0;
}

int run_plan_calibrate(const PlanCalibrateOptions& o) {
  if (o.fit) return run_plan_calibrate_fit(o);
  if (o.protocol.empty())
    throw std::runtime_error("plan calibrate: --protocol is required without --fit "
                             "(examples/protocols/calibration.json)");
  const protocols::Protocol protocol = protocols::load_protocol_file(o.protocol);
  const ChosenPopulation chosen = choose_population(o.population);
  planning::SimulatedStudyOptions sim;
  sim.rate_Hz = o.rate_Hz > 0.0 ? o.rate_Hz : 1000.0;
  sim.max_trial_s = o.max_trial_s;
  sim.population = chosen.point;
  analysis::StudyAnalysis names;
  for (const auto& s : protocol.settings) names.settings.push_back(s.settings.name);
  try {
    analysis::choose_control(names, sim.analysis);
  } catch (const std::exception& e) {
    throw std::runtime_error(o.protocol + ": " + e.what() + "; plan calibrate compares No Force Feedback with it");
  }
  // No Force Feedback by what it does, not its name: the tip force clipped to 0 N.
  std::string no_feedback;
  for (const auto& s : protocol.settings) {
    const auto& t = s.settings.engine.tip_force_saturation;
    if (t.enabled && t.limit_N == 0.0 && no_feedback.empty()) no_feedback = s.settings.name;
  }
  if (no_feedback.empty())
    throw std::runtime_error(o.protocol + ": no setting displays no force (tip_force_saturation enabled with "
                             "limit_N 0, as examples/settings/no_force_feedback.json); plan calibrate measures "
                             "the published effects of force feedback against it");
  // A design that cannot take the group sizes is refused before anything runs.
  (void)planning::resized_protocol(protocol, std::min(o.participants, planning::kCalibrationGroup), o.seed);
  if (const int rest = o.participants % planning::kCalibrationGroup; rest > 0)
    (void)planning::resized_protocol(protocol, rest, o.seed);

  prepare_out_folder(o.out);

  ProgressLine line(o.json ? stderr : stdout);
  line.print("simulating " + std::to_string(o.participants) + " participants of " + protocol.study + " (" +
             no_feedback + " against " + names.control + ") from the " + chosen.describe);
  InterruptFlag interrupt;
  const auto started = std::chrono::steady_clock::now();
  const planning::SimulatedPopulation population = planning::simulate_population(
      protocol, o.participants, o.seed, o.jobs, sim, planning::kCalibrationGroup,
      [&](int done_participants) {
        const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        std::optional<double> eta;
        if (done_participants > 0)
          eta = elapsed_s / done_participants * static_cast<double>(o.participants - done_participants);
        line.update(static_cast<double>(done_participants) / o.participants,
                    std::to_string(done_participants) + "/" + std::to_string(o.participants) + " participants",
                    elapsed_s, eta);
      },
      [&] { return interrupt.raised(); });
  line.finish();
  if (interrupt.raised()) throw std::runtime_error("interrupted; nothing written (run it again)");
  const analysis::StudyAnalysis& all = population.analysis;
  const std::size_t timed_out = population.trials_timed_out;
  const std::vector<planning::MeasuredEffect> effects = planning::measure_effects(all, names.control, no_feedback);

  std::ostringstream csv;
  csv << "id,task,what,published,source,criterion,participants,median_ratio,q1,q3,share_above_1,consistent\n";
  for (const auto& e : effects)
    csv << e.effect.id << ',' << e.effect.task << ',' << csv_text(e.effect.what) << ',' << csv_text(e.effect.published)
        << ',' << csv_text(e.effect.source) << ',' << csv_text(e.effect.criterion) << ',' << e.participants << ','
        << format_number(e.median) << ',' << format_number(e.q1) << ',' << format_number(e.q3) << ','
        << format_number(e.share_above_one) << ',' << (e.consistent ? "yes" : "no") << '\n';
  const fs::path csv_path = fs::path(o.out) / "calibration.csv";
  try {
    write_file_atomically(csv_path, csv.str());
  } catch (const OutputFileError& e) {
    throw std::runtime_error(std::string(e.what()) + " (disk full?); nothing else was written");
  }
  if (o.json) {
    nlohmann::json j = {{"participants", o.participants}, {"control", names.control}, {"no_feedback", no_feedback},
                        {"trials_timed_out", timed_out}, {"effects", nlohmann::json::array()},
                        {"csv", csv_path.string()}};
    for (const auto& e : effects)
      j["effects"].push_back({{"id", e.effect.id}, {"task", e.effect.task}, {"published", e.effect.published},
                              {"source", e.effect.source}, {"criterion", e.effect.criterion},
                              {"participants", e.participants}, {"median_ratio", e.median}, {"q1", e.q1},
                              {"q3", e.q3}, {"share_above_1", e.share_above_one}, {"consistent", e.consistent}});
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("\n%d simulated participants (%zu trials timed out and left out); each effect is a ratio of one "
              "participant's medians, summarized over them\n\n",
              o.participants, timed_out);
  for (const auto& e : effects) {
    std::printf("%s: %s\n  published: %s (%s)\n  simulated: median %.2f [Q1 %.2f, Q3 %.2f], > 1 for %.0f%% of %zu "
                "participants; %s: %s\n\n",
                e.effect.task.c_str(), e.effect.what.c_str(), e.effect.published.c_str(), e.effect.source.c_str(),
                e.median, e.q1, e.q3, 100.0 * e.share_above_one, e.participants, e.effect.criterion.c_str(),
                e.consistent ? "consistent" : "NOT consistent");
  }
  std::printf("Table: %s\n", csv_path.c_str());
  return 0;
}

// --shard I/N of plan power (a Slurm job array's part of the plan).
void add_shard_option(CLI::App* cmd, PlanPowerOptions& options) {
  PlanPowerOptions* opt = &options;
  cmd->add_option_function<std::string>(
         "--shard",
         [opt](const std::string& v) {
           const auto slash = v.find('/');
           const auto whole = [](const std::string& t, long long lo, long long hi) -> std::optional<int> {
             if (t.empty() || t.size() > 6 || t.find_first_not_of("0123456789") != std::string::npos) return {};
             const long long x = std::stoll(t);
             return x >= lo && x <= hi ? std::optional<int>(static_cast<int>(x)) : std::nullopt;
           };
           const std::optional<int> n = slash == std::string::npos ? std::nullopt : whole(v.substr(slash + 1), 1, 100000);
           const std::optional<int> i = n ? whole(v.substr(0, slash), 0, *n - 1) : std::nullopt;
           if (!i)
             throw CLI::ValidationError("--shard", "'" + v + "' is not I/N with 0 <= I < N <= 100000 (shard I of N, "
                                                   "counting from 0: --shard 0/3, 1/3, 2/3)");
           opt->shard = *i;
           opt->shards = *n;
         },
         "This run's part of the plan, I/N (0 <= I < N): the studies k (the plan's, in order) with k mod N = I, the "
         "same ones a one-machine run simulates, into this --out; `plan merge` joins the N folders. For a Slurm job "
         "array (scripts/slurm/)")
      ->type_name("I/N");
}

}  // namespace

void add_plan_command(CLI::App& app) {
  CLI::App* plan = app.add_subcommand("plan", "Plan a study before recruiting anyone: simulate it many times");
  plan->require_subcommand(1);
  auto opt = std::make_shared<PlanPowerOptions>();
  CLI::App* cmd = plan->add_subcommand(
      "power",
      "Simulation-based power: run the protocol's study many times on the simulated rig (virtual clock, fresh "
      "seeds, no samples stored), analyse each the thesis' way, and report how often each setting differs "
      "significantly from the control, per number of participants, with Wilson 95 % intervals. Resumes when "
      "run again with the same --out.");
  cmd->add_option("--protocol", opt->protocol, "Protocol file (examples/protocols/*.json)")
      ->required()
      ->check(CLI::ExistingFile);
  add_list_option(*cmd, "--participants", opt->participants,
                  "Participant counts to simulate, comma-separated (default: the protocol's), each 1..999",
                  whole_number_in(1, 999));
  cmd->add_option("--studies", opt->studies, "Simulated studies per participant count, 1..100000")
      ->capture_default_str()
      ->check(whole_number_in(1, 100000));
  add_seed_option(*cmd, opt->seed, "Seed of the whole plan: the same seed gives the same studies");
  add_jobs_option(*cmd, opt->jobs, "Studies simulated at once (0: two per core)")->capture_default_str();
  cmd->add_option("--out", opt->out, "Folder for plan_power.db (the finished studies), power.csv and figures")
      ->capture_default_str();
  cmd->add_option("--measure", opt->measure, "Measure of the printed table and figures (power.csv has all)")
      ->capture_default_str()
      ->check(CLI::IsMember({"force_median_N", "force_p95_N", "completion_time_s", "speed_median_m_per_s",
                             "path_length_m"}));
  add_loop_rate_option(*cmd, opt->rate_Hz, "Haptic loop rate of the simulated trials [Hz], 150..2000, as session run's")
      ->capture_default_str();
  cmd->add_option("--max-trial-s", opt->max_trial_s, "Per-trial time limit [s], as session run's")
      ->capture_default_str()
      ->check(positive_number());
  cmd->add_flag("--no-plots", [opt](std::int64_t) { opt->plots = false; }, "No figures (no gnuplot needed)");
  cmd->add_flag("--json", opt->json, "Print the power table as JSON (progress goes to stderr)");
  add_shard_option(cmd, *opt);
  add_population_option(cmd, opt->population);
  cmd->add_option("--model-uncertainty", opt->model_uncertainty,
                  "on: each study draws its participants' population from the fitted population's posterior, and "
                  "power gets a 95 % interval that includes the model's uncertainty beside the simulation-only one; "
                  "off: every study uses the point estimate (default: on when the population is a fitted file)")
      ->check(CLI::IsMember({"on", "off", "auto"}))
      ->capture_default_str();
  add_transfer_options(cmd, *opt);
  cmd->callback([opt, cmd] {
    opt->measure_given = cmd->count("--measure") > 0;
    const int status = run_plan_power(*opt);
    if (status != 0) throw CLI::RuntimeError(status);
  });

  auto mo = std::make_shared<PlanMergeOptions>();
  CLI::App* merge = plan->add_subcommand(
      "merge",
      "Join the folders of one plan's shards (plan power --shard I/N, e.g. a Slurm job array) into one plan: checks "
      "they are the shards of one plan (protocol, settings, options, seed, version), each once and all of them, "
      "complete and undamaged, then writes what a one-machine run of the plan writes (power.csv, comparison.md, "
      "predicted_change.csv, figures), byte for byte. The shards' folders are only read.");
  merge->add_option("shards", mo->shards, "The shards' --out folders")->required()->check(CLI::ExistingDirectory);
  merge->add_option("--out", mo->out, "Folder for the merged plan (not one of the shards')")->required();
  merge->add_option("--protocol", mo->protocol,
                    "The protocol file, when it is not where the shards' runs read it (its text and settings must be "
                    "the same)")
      ->check(CLI::ExistingFile);
  merge->add_option("--measure", mo->measure, "Measure of the printed table and figures (power.csv has all)")
      ->capture_default_str()
      ->check(CLI::IsMember({"force_median_N", "force_p95_N", "completion_time_s", "speed_median_m_per_s",
                             "path_length_m"}));
  merge->add_flag("--no-plots", [mo](std::int64_t) { mo->plots = false; }, "No figures (no gnuplot needed)");
  merge->add_flag("--json", mo->json, "Print the power table as JSON");
  merge->callback([mo] {
    const int status = run_plan_merge(*mo);
    if (status != 0) throw CLI::RuntimeError(status);
  });
  auto cal = std::make_shared<PlanCalibrateOptions>();
  CLI::App* calibrate = plan->add_subcommand(
      "calibrate",
      "Does the simulated population show the published effects of force feedback? Runs the protocol (with "
      "High Fidelity and a No Force Feedback setting) for many simulated participants and prints each effect "
      "(Wagner et al. 2002, the thesis) beside the measured one; writes calibration.csv");
  calibrate->add_option("--protocol", cal->protocol,
                        "Protocol file (examples/protocols/calibration.json); with --fit, the thesis design "
                        "(default: the shipped examples/protocols/thesis_as_run.json)")
      ->check(CLI::ExistingFile);
  calibrate->add_flag("--fit", cal->fit,
                      "Fit the population to the calibration set instead (docs/simulation.md, \"Fitting the "
                      "population\"): writes population.json (when the fit converged), fit_targets.csv, "
                      "fit_parameters.csv and fit_summary.json to --out");
  calibrate->add_option("--fit-studies", cal->fit_studies,
                        "With --fit: simulated 3-surgeon studies per design population (9 of them), 1..1000")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  add_population_option(calibrate, cal->population);
  calibrate->add_option("--participants", cal->participants, "Simulated participants, 2..100000")
      ->capture_default_str()
      ->check(whole_number_in(2, 100000));
  add_seed_option(*calibrate, cal->seed, "Seed: the same seed gives the same participants and table");
  add_jobs_option(*calibrate, cal->jobs, "Groups of 10 participants simulated at once (0: two per core)");
  calibrate->add_option("--out", cal->out, "Folder for calibration.csv")->capture_default_str();
  add_loop_rate_option(*calibrate, cal->rate_Hz,
                       "Haptic loop rate of the simulated trials [Hz], 150..2000 (default 1000; 250 with --fit, "
                       "whose rate check compares 1 kHz)");
  calibrate->add_option("--max-trial-s", cal->max_trial_s, "Per-trial time limit [s], as session run's")
      ->capture_default_str()
      ->check(number_in(1.0, 3600.0));
  calibrate->add_flag("--json", cal->json, "Print the table as JSON (progress goes to stderr)");
  calibrate->callback([cal] {
    cal->command = "hapticlab plan calibrate --fit --fit-studies " + std::to_string(cal->fit_studies) + " --seed " +
                   std::to_string(cal->seed) +
                   (cal->rate_Hz > 0.0 ? " --rate-hz " + format_number(cal->rate_Hz) : std::string()) +
                   (cal->protocol.empty() ? std::string() : " --protocol " + cal->protocol) + " --out " + cal->out;
    (void)run_plan_calibrate(*cal);
  });
}

}  // namespace hapticlab::app
