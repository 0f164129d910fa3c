// `hapticlab plan calibrate`: its options; the simulated population against
// the published effects of force feedback (planning/calibration.h), or with
// --fit the population fitted to the calibration set (planning/population_fit.h,
// planning/fit_diagnostics.h), with a progress line, and the tables printed.
#include "app/plan/plan_subcommands.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>

#include "app/cli/data_paths.h"
#include "app/cli/cli_checks.h"
#include "app/cli/interrupt_flag.h"
#include "app/cli/option_shapes.h"
#include "app/cli/population_option.h"
#include "app/cli/progress_line.h"
#include "core/common/csv_format.h"
#include "core/common/output_file.h"
#include "planning/calibration.h"
#include "planning/fit_diagnostics.h"
#include "planning/plan_folder.h"
#include "planning/plan_inputs.h"
#include "planning/population_fit.h"
#include "protocols/protocol_json.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

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

// The fit, its stages on a progress line.
planning::PopulationFitResult fit_with_progress(const PlanCalibrateOptions& o, const protocols::Protocol& protocol,
                                                const planning::PopulationFitOptions& fit,
                                                const InterruptFlag& interrupt) {
  ProgressLine line(o.json ? stderr : stdout);
  line.print("fitting the simulated population to the calibration set (docs/simulation.md): " +
             std::to_string(9 * o.fit_studies) + " simulated 3-surgeon studies of " + protocol.study + " at " +
             format_number(fit.rate_Hz) + " Hz, then the posterior on a grid");
  const auto started = std::chrono::steady_clock::now();
  std::string stage;
  double stage_started_s = 0.0;
  planning::PopulationFitResult r = planning::fit_population(
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
  return r;
}

void print_fit_json(const planning::PopulationFitResult& r, const planning::FitFiles& files) {
  nlohmann::json j = files.summary;
  j["population_file"] = r.converged ? nlohmann::json(files.population.string()) : nlohmann::json();
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
}

void print_fit_text(const planning::PopulationFitResult& r, const planning::FitFiles& files) {
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
              r.converged ? ("population written to " + files.population.string()).c_str()
                          : "did not converge (below)");
  std::printf("Diagnostics: %s, %s, %s\n", files.targets.c_str(), files.parameters.c_str(),
              files.summary_file.c_str());
}

// `plan calibrate --fit`: the population fitted to the calibration set.
// Writes DIR/population.json (only when the fit converged),
// DIR/fit_targets.csv, DIR/fit_parameters.csv and DIR/fit_summary.json.
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
  planning::prepare_plan_folder(o.out);
  InterruptFlag interrupt;
  const planning::PopulationFitResult r = fit_with_progress(o, protocol, fit, interrupt);
  // Diagnostics, whatever the outcome.
  const planning::FitFiles files = planning::write_fit_files(r, o.out);
  if (o.json)
    print_fit_json(r, files);
  else
    print_fit_text(r, files);
  if (!r.converged) {
    std::string why;
    for (const auto& p : r.problems) why += "\n  - " + p;
    throw std::runtime_error(std::string("the fit did not converge; no population.json was written") +
                             (files.removed_earlier_population ? " (an earlier fit's population.json was removed)" : "") +
                             " (diagnostics are in " + o.out + "):" + why);
  }
  return 0;
}

planning::SimulatedPopulation simulate_with_progress(const PlanCalibrateOptions& o, const protocols::Protocol& protocol,
                                                     const planning::SimulatedStudyOptions& sim,
                                                     const InterruptFlag& interrupt, ProgressLine& line) {
  const auto started = std::chrono::steady_clock::now();
  planning::SimulatedPopulation population = planning::simulate_population(
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
  return population;
}

void print_calibration_json(const PlanCalibrateOptions& o, const planning::CalibrationSettings& names,
                            std::size_t timed_out, const std::vector<planning::MeasuredEffect>& effects,
                            const fs::path& csv_path) {
  nlohmann::json j = {{"participants", o.participants}, {"control", names.control}, {"no_feedback", names.no_feedback},
                      {"trials_timed_out", timed_out}, {"effects", nlohmann::json::array()},
                      {"csv", csv_path.string()}};
  for (const auto& e : effects)
    j["effects"].push_back({{"id", e.effect.id}, {"task", e.effect.task}, {"published", e.effect.published},
                            {"source", e.effect.source}, {"criterion", e.effect.criterion},
                            {"participants", e.participants}, {"median_ratio", e.median}, {"q1", e.q1},
                            {"q3", e.q3}, {"share_above_1", e.share_above_one}, {"consistent", e.consistent}});
  std::printf("%s\n", j.dump(2).c_str());
}

void print_calibration_text(const PlanCalibrateOptions& o, std::size_t timed_out,
                            const std::vector<planning::MeasuredEffect>& effects, const fs::path& csv_path) {
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
  const planning::CalibrationSettings names =
      planning::check_calibration_protocol(protocol, o.protocol, o.participants, o.seed, sim);
  planning::prepare_plan_folder(o.out);
  ProgressLine line(o.json ? stderr : stdout);
  line.print("simulating " + std::to_string(o.participants) + " participants of " + protocol.study + " (" +
             names.no_feedback + " against " + names.control + ") from the " + chosen.describe);
  InterruptFlag interrupt;
  const planning::SimulatedPopulation population = simulate_with_progress(o, protocol, sim, interrupt, line);
  if (interrupt.raised()) throw std::runtime_error("interrupted; nothing written (run it again)");
  const std::size_t timed_out = population.trials_timed_out;
  const std::vector<planning::MeasuredEffect> effects =
      planning::measure_effects(population.analysis, names.control, names.no_feedback);
  const fs::path csv_path = fs::path(o.out) / "calibration.csv";
  try {
    write_file_atomically(csv_path, planning::calibration_csv(effects));
    // What the table was made from: the protocol's and settings' hashes,
    // the options, the population and the software.
    planning::PlanInputs inputs = planning::plan_inputs(protocol, o.protocol, protocols::read_protocol_text(o.protocol),
                                                        o.seed, {o.participants}, 1, sim);
    inputs.population = chosen.key;
    planning::write_inputs_record(fs::path(o.out) / "calibration.inputs.json", inputs,
                                  {{"design", "calibration: one simulated population of --participants"}});
  } catch (const OutputFileError& e) {
    throw std::runtime_error(std::string(e.what()) + " (disk full?); nothing else was written");
  }
  if (o.json)
    print_calibration_json(o, names, timed_out, effects, csv_path);
  else
    print_calibration_text(o, timed_out, effects, csv_path);
  return 0;
}

// --protocol, --fit, --fit-studies, --population, --participants, --seed, --jobs.
void add_calibrate_design_options(CLI::App* calibrate, PlanCalibrateOptions& cal) {
  calibrate->add_option("--protocol", cal.protocol,
                        "Protocol file (examples/protocols/calibration.json); with --fit, the thesis design "
                        "(default: the shipped examples/protocols/thesis_as_run.json)")
      ->check(CLI::ExistingFile);
  calibrate->add_flag("--fit", cal.fit,
                      "Fit the population to the calibration set instead (docs/simulation.md, \"Fitting the "
                      "population\"): writes population.json (when the fit converged), fit_targets.csv, "
                      "fit_parameters.csv and fit_summary.json to --out");
  calibrate->add_option("--fit-studies", cal.fit_studies,
                        "With --fit: simulated 3-surgeon studies per design population (9 of them), 1..1000")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  add_population_option(calibrate, cal.population);
  calibrate->add_option("--participants", cal.participants, "Simulated participants, 2..100000")
      ->capture_default_str()
      ->check(whole_number_in(2, 100000));
  add_seed_option(*calibrate, cal.seed, "Seed: the same seed gives the same participants and table");
  add_jobs_option(*calibrate, cal.jobs, "Groups of 10 participants simulated at once (0: two per core)");
  // Refused rather than ignored: the fit draws its own participants (its
  // design populations), and --fit-studies means nothing without it.
  CLI::Option* fit = calibrate->get_option("--fit");
  for (const char* unused_by_the_fit : {"--population", "--participants"})
    calibrate->get_option(unused_by_the_fit)->excludes(fit);
  calibrate->get_option("--fit-studies")->needs(fit);
}

}  // namespace

void add_plan_calibrate_subcommand(CLI::App* plan) {
  auto cal = std::make_shared<PlanCalibrateOptions>();
  CLI::App* calibrate = plan->add_subcommand(
      "calibrate",
      "Does the simulated population show the published effects of force feedback? Runs the protocol (with "
      "High Fidelity and a No Force Feedback setting) for many simulated participants and prints each effect "
      "(Wagner et al. 2002, the thesis) beside the measured one; writes calibration.csv");
  add_calibrate_design_options(calibrate, *cal);
  calibrate->add_option("--out", cal->out, "Folder for calibration.csv")->capture_default_str();
  add_loop_rate_option(*calibrate, cal->rate_Hz,
                       "Haptic loop rate of the simulated trials [Hz], 150..2000 (default 1000; 250 with --fit, "
                       "whose rate check compares 1 kHz)");
  add_trial_limit_option(*calibrate, cal->max_trial_s, "Per-trial time limit [s], 1..3600, as session run's")
      ->capture_default_str();
  calibrate->add_flag("--json", cal->json, "Print the table as JSON (progress goes to stderr)");
  calibrate->callback([cal] {
    cal->command = "hapticlab plan calibrate --fit --fit-studies " + std::to_string(cal->fit_studies) + " --seed " +
                   std::to_string(cal->seed) +
                   (cal->rate_Hz > 0.0 ? " --rate-hz " + format_number(cal->rate_Hz) : std::string()) +
                   (cal->max_trial_s != PlanCalibrateOptions{}.max_trial_s
                        ? " --max-trial-s " + format_number(cal->max_trial_s)
                        : std::string()) +
                   (cal->protocol.empty() ? std::string() : " --protocol " + cal->protocol) + " --out " + cal->out;
    (void)run_plan_calibrate(*cal);
  });
}

}  // namespace hapticlab::app
