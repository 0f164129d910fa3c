#include "app/study/stats_learning.h"

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "analysis/io/long_csv.h"
#include "analysis/learning/learning_analysis.h"
#include "analysis/learning/learning_figures.h"
#include "analysis/learning/trial_table.h"
#include "analysis/report/gnuplot.h"
#include "analysis/stats/data_error.h"
#include "analysis/transfer/transfer_analysis.h"
#include "core/common/output_file.h"
#include "planning/plan_folder.h"

namespace hapticlab::app {
namespace {

namespace an = hapticlab::analysis;
namespace fs = std::filesystem;

struct TableOptions {
  std::string csv;
  an::learning::TrialColumns columns;
};

void add_table_options(CLI::App& cmd, TableOptions& opt) {
  cmd.add_option("TRIALS", opt.csv, "Trial table CSV: participant, group, phase (pre/training/post/retention), trial, measure")
      ->required();
  cmd.add_option("--measure", opt.columns.measure, "Measure column (e.g. completion_time_s, force_p95_N)")
      ->capture_default_str();
  cmd.add_option("--participant-column", opt.columns.participant, "Column naming the participant")->capture_default_str();
  cmd.add_option("--group-column", opt.columns.group, "Column naming the participant's group")->capture_default_str();
  cmd.add_option("--phase-column", opt.columns.phase, "Column naming the phase: pre, training, post, retention")
      ->capture_default_str();
  cmd.add_option("--trial-column", opt.columns.trial, "Column with the 1-based trial index within the phase")
      ->capture_default_str();
}

an::learning::Phase parse_phase(const std::string& name) {
  using an::learning::Phase;
  for (Phase p : {Phase::kPre, Phase::kTraining, Phase::kPost, Phase::kRetention})
    if (name == an::learning::phase_name(p)) return p;
  throw an::DataError("--phase '" + name + "' (allowed: pre, training, post, retention)");
}

struct LearningOptions {
  TableOptions table;
  std::string phase = "training";
  std::string out;
  std::optional<double> criterion;
  bool higher_is_better = false;
  an::learning::CusumSpec spec;
  std::optional<double> lc_limit;
  bool no_figures = false;
};

// Complete or absent, with the cause (output_file.h): written in place, a
// full disk left a truncated curves.csv that looked like a result.
void write_file(const fs::path& path, const std::string& text) {
  try {
    write_file_atomically(path, text);
  } catch (const OutputFileError& e) {
    throw an::DataError(e.what());
  }
}

void run_learning(const LearningOptions& opt) {
  const auto table = an::learning::read_trial_table(an::LongCsv::read(opt.table.csv), opt.table.columns);
  std::optional<an::learning::CusumCriterion> cusum;
  if (opt.criterion) {
    cusum = an::learning::CusumCriterion{*opt.criterion, opt.higher_is_better, opt.spec};
    cusum->spec.lc_limit = opt.lc_limit;
  }
  const auto analysis = an::learning::analyze_learning(table, parse_phase(opt.phase), cusum);
  planning::prepare_plan_folder(opt.out, "nothing was written");
  std::ostringstream curves;
  an::learning::write_curves_csv(analysis, curves);
  write_file(fs::path(opt.out) / "curves.csv", curves.str());
  if (cusum) {
    std::ostringstream c;
    an::learning::write_cusum_csv(analysis, c);
    write_file(fs::path(opt.out) / "cusum.csv", c.str());
  }
  std::cout << "Learning curves of " << analysis.measure << " over the " << opt.phase
            << " trials (family by AICc; trials to 90 %: where the excess over the plateau is 10 % of trial 1's)\n";
  std::cout << std::setprecision(4);
  for (const auto& p : analysis.participants) {
    std::cout << "  " << p.participant << " (" << p.group << ", " << p.trial.size() << " trials): ";
    if (!p.curve.chosen) {
      std::cout << "no curve: " << p.curve.fits[0].reason << "; " << p.curve.fits[1].reason << "\n";
    } else {
      const auto& f = p.curve.fit(*p.curve.chosen);
      std::cout << an::learning::family_name(f.family) << ", plateau " << f.a << " (SE " << f.se_a << ")";
      if (f.family == an::learning::CurveFamily::kPower) std::cout << ", c " << f.rate << " (SE " << f.se_rate << ")";
      if (f.family == an::learning::CurveFamily::kExponential) std::cout << ", tau " << f.rate << " trials (SE " << f.se_rate << ")";
      if (f.family != an::learning::CurveFamily::kConstant) {
        std::cout << ", trials to 90 % " << f.trials_to_90 << (f.trials_to_90_beyond_data ? " (beyond the data)" : "");
      }
      std::cout << ", residual SD " << f.residual_sd << ", Akaike weight " << p.curve.akaike_weight_chosen << "\n";
    }
    if (p.cusum) {
      std::cout << "    CUSUM (s " << p.cusum->s << ", h1 " << p.cusum->h1 << ", h0 " << p.cusum->h0 << "): ";
      if (p.cusum->first_below_h0) std::cout << "acceptable (p0) at trial " << *p.cusum->first_below_h0;
      else std::cout << "not shown acceptable";
      if (p.cusum->first_above_h1) std::cout << "; unacceptable (p1) signalled at trial " << *p.cusum->first_above_h1;
      if (p.cusum->lc_proficient_at) std::cout << "; LC-CUSUM proficient at trial " << *p.cusum->lc_proficient_at;
      std::cout << "\n";
    }
  }
  std::cout << "Wrote " << (fs::path(opt.out) / "curves.csv").string();
  if (cusum) std::cout << ", cusum.csv";
  if (!opt.no_figures) {
    const auto files = an::learning::write_learning_figures(analysis, opt.out, an::find_gnuplot());
    std::cout << " and " << files.size() << " figure files";
  }
  std::cout << "\n";
}

struct TransferCliOptions {
  TableOptions table;
  an::transfer::TransferOptions options;
  std::optional<std::string> control, reference;
  std::optional<double> criterion;
};

}  // namespace

void add_stats_learning_commands(CLI::App& stats) {
  {
    auto opt = std::make_shared<LearningOptions>();
    CLI::App* cmd = stats.add_subcommand(
        "learning", "Learning curves per participant (power law and exponential, chosen by AICc) and the CUSUM "
                    "learning curve against a proficiency criterion (issue 38)");
    add_table_options(*cmd, opt->table);
    cmd->add_option("--phase", opt->phase, "Phase whose trials form the curve")->capture_default_str();
    cmd->add_option("--out", opt->out, "Folder for curves.csv, cusum.csv and the figures")->required();
    cmd->add_option("--cusum-criterion", opt->criterion,
                    "Proficiency criterion in the measure's unit: a trial fails above it (below with --higher-is-better)");
    cmd->add_flag("--higher-is-better", opt->higher_is_better, "The measure is better when higher");
    cmd->add_option("--p0", opt->spec.p0, "Acceptable failure rate")->capture_default_str();
    cmd->add_option("--p1", opt->spec.p1, "Unacceptable failure rate (> p0)")->capture_default_str();
    cmd->add_option("--alpha", opt->spec.alpha, "CUSUM type I error")->capture_default_str();
    cmd->add_option("--beta", opt->spec.beta, "CUSUM type II error")->capture_default_str();
    cmd->add_option("--lc-limit", opt->lc_limit, "LC-CUSUM decision limit h (log-likelihood units)");
    cmd->add_flag("--no-figures", opt->no_figures, "Skip the gnuplot figures");
    cmd->callback([opt] { run_learning(*opt); });
  }
  {
    auto opt = std::make_shared<TransferCliOptions>();
    CLI::App* cmd = stats.add_subcommand(
        "transfer", "Groups compared on post-test and retention change from the pre-test (exact rank permutation "
                    "test, Hodges-Lehmann shift), and Roscoe's transfer effectiveness ratio (issue 38)");
    add_table_options(*cmd, opt->table);
    cmd->add_option("--control-group", opt->control, "Group trained on no simulator (for the TER; reference of the shifts)");
    cmd->add_option("--reference-group", opt->reference, "Reference of the shifts (default: control, else the first group)");
    cmd->add_option("--criterion", opt->criterion, "Proficiency criterion for the TER's post-test trials to criterion");
    cmd->add_flag("--higher-is-better", opt->options.higher_is_better, "The measure is better when higher");
    cmd->add_option("--monte-carlo", opt->options.permutation.monte_carlo,
                    "Draws when there are more than 10^6 assignments (>= 1000)")
        ->capture_default_str();
    cmd->add_option("--seed", opt->options.permutation.seed, "Monte Carlo seed")->capture_default_str();
    cmd->callback([opt] {
      an::transfer::TransferOptions o = opt->options;
      o.control_group = opt->control;
      o.reference_group = opt->reference;
      o.criterion = opt->criterion;
      const auto table = an::learning::read_trial_table(an::LongCsv::read(opt->table.csv), opt->table.columns);
      an::transfer::write_transfer_text(an::transfer::analyze_transfer(table, o), std::cout);
    });
  }
}

}  // namespace hapticlab::app
