#include "app/study/stats_command.h"
#include "app/study/stats_learning.h"

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <tuple>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/io/long_csv.h"
#include "analysis/io/row_groups.h"
#include "analysis/stats/block_table.h"
#include "analysis/stats/correlation.h"
#include "analysis/stats/data_error.h"
#include "analysis/stats/durbin.h"
#include "analysis/stats/friedman.h"
#include "analysis/stats/kolmogorov_smirnov.h"
#include "analysis/stats/ks_bootstrap.h"
#include "analysis/stats/ks_samples.h"
#include "analysis/stats/effect_size.h"
#include "analysis/stats/pairwise_friedman.h"
#include "analysis/stats/percentile.h"
#include "analysis/stats/sign_flip_vs_control.h"
#include "analysis/stats/skillings_mack.h"
#include "app/cli/cli_checks.h"
#include "app/cli/option_shapes.h"

namespace hapticlab::app {
namespace {

namespace an = hapticlab::analysis;
using nlohmann::json;

// Options shared by the block-design subcommands.
struct CommonOptions {
  std::string csv;
  an::LongColumns columns;
  std::vector<std::string> group;
  bool json = false;
  bool drop_missing = false;
};

struct PairwiseOptions {
  CommonOptions common;
  std::string control;
  double alpha = 0.05;
  std::string method = "thesis";  // or "participant": one value per block, sign-flip test
  std::string percentile_method = "matlab";  // the medians of --method participant
};

struct CorrelationOptions {
  std::string csv;
  std::string x;
  std::string y;
  std::vector<std::string> group;
  bool json = false;
  bool drop_missing = false;
};

struct KsOptions {
  CommonOptions common;
  std::string control;
  std::string other;
  std::size_t bootstrap = 0;
  std::size_t block_length = 0;
  std::uint64_t seed = 1;
  std::string percentile_method = "matlab";
  bool block_given = false;  // --block on the command line
};

std::string num(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

// The CSV, refused when it holds no data rows: a test of nothing must not
// look like a result (it used to print nothing and exit 0).
// With drop_missing, rows with an empty cell in one of `value_columns` are
// left out and counted on stderr: metrics.csv leaves a measure empty when a
// trial has no task window, and an analysis of the rest is what a user wants.
an::LongCsv read_data(const std::string& path, bool drop_missing, const std::vector<std::string>& value_columns) {
  an::LongCsv csv = an::LongCsv::read(path);
  if (drop_missing) {
    std::size_t dropped = 0;
    csv = csv.without_empty(value_columns, dropped);
    if (dropped > 0) {
      std::string names;
      for (const std::string& c : value_columns) names += (names.empty() ? "" : ", ") + c;
      std::fprintf(stderr, "hapticlab stats: left out %zu row(s) of %s with an empty %s\n", dropped, path.c_str(),
                   names.c_str());
    }
  }
  if (csv.row_count() == 0) {
    throw an::DataError(path + ": the file has a header row but no data rows; nothing to test");
  }
  return csv;
}

void add_csv_option(CLI::App& cmd, std::string& csv) {
  cmd.add_option("--csv", csv,
                 "Long-format CSV: a header row of column names, then one observation per row")
      ->required();
}

void add_group_option(CLI::App& cmd, std::vector<std::string>& group) {
  add_list_option(cmd, "--group", group,
                  "Column(s) to split the data by (repeat the option or separate with commas); "
                  "one result per distinct combination, e.g. --group participant,task");
}

void add_drop_missing_flag(CLI::App& cmd, bool& drop_missing) {
  cmd.add_flag("--drop-missing", drop_missing,
               "Leave out rows whose value is empty (as metrics.csv has for a trial without a task window), "
               "counted on stderr; without it an empty value is an error");
}

void add_common_options(CLI::App& cmd, CommonOptions& opt, bool with_group) {
  add_csv_option(cmd, opt.csv);
  cmd.add_option("--block", opt.columns.block,
                 "Column naming the block (participant, or participant x instrument)")
      ->capture_default_str();
  cmd.add_option("--treatment", opt.columns.treatment,
                 "Column naming the treatment (hardware setting)")
      ->capture_default_str();
  cmd.add_option("--replicate", opt.columns.replicate,
                 "Column naming the repetition (optional; without it, several rows of one block "
                 "and treatment are replicates in file order; with it, the block tests refuse a "
                 "block, treatment and replicate that occur twice)");
  cmd.add_option("--value", opt.columns.value, "Column holding the measured value")
      ->capture_default_str();
  if (with_group) add_group_option(cmd, opt.group);
  add_drop_missing_flag(cmd, opt.drop_missing);
  cmd.add_flag("--json", opt.json, "Print one JSON object instead of a table");
}

// Rows split by the --group columns (analysis/io/row_groups.h), with the
// group's key as JSON for --json.
struct Group {
  json key = json::object();  // column -> value
  std::string label;          // "participant=S1, task=clip"
  std::vector<std::size_t> rows;
};

std::vector<Group> split_groups(const an::LongCsv& csv, const std::vector<std::string>& columns) {
  std::vector<Group> groups;
  for (an::RowGroup& g : an::split_rows(csv, columns)) {
    Group& out = groups.emplace_back();
    for (const auto& [column, value] : g.key) out.key[column] = value;
    out.label = std::move(g.label);
    out.rows = std::move(g.rows);
  }
  return groups;
}

// With --replicate, a block test's (block, treatment, replicate) names one
// observation: a repeated one (a file pasted onto itself, two tasks left in
// one group) would be ranked as one more replicate and inflate the test
// (chi-square 7.84 => 17.26 for a doubled file), so it is refused, naming
// both lines. (ks --bootstrap's replicate column labels series of many
// rows; it does not come here.)
void refuse_repeated_replicates(const an::LongCsv& csv, const std::vector<an::Observation>& all, const Group& group,
                                const std::string& replicate_column) {
  if (replicate_column.empty()) return;
  std::map<std::tuple<std::string, std::string, std::string>, std::size_t> first_row;
  for (std::size_t r : group.rows) {
    const an::Observation& o = all[r];
    const auto [it, inserted] = first_row.emplace(std::tuple{o.block, o.treatment, o.replicate}, r);
    if (inserted) continue;
    throw an::DataError(csv.source() + ": lines " + std::to_string(csv.line(it->second)) + " and " +
                        std::to_string(csv.line(r)) + " are both block '" + o.block + "', treatment '" + o.treatment +
                        "', replicate '" + o.replicate + "' (--replicate " + replicate_column +
                        "): each replicate is one observation, and a repeated one would count as another; "
                        "remove the repeat, or --group by the column that tells them apart");
  }
}

an::BlockTable table_for(const an::LongCsv& csv, const std::vector<an::Observation>& all, const Group& group,
                         const std::string& replicate_column) {
  refuse_repeated_replicates(csv, all, group, replicate_column);
  std::vector<an::Observation> subset;
  subset.reserve(group.rows.size());
  for (std::size_t r : group.rows) subset.push_back(all[r]);
  return an::BlockTable::from_observations(subset);
}

// Runs `per_group` for every group and prints either the tables or one JSON
// object: the group's result directly when there is no --group, else
// {"test": ..., "groups": [{"group": {...}, ...}, ...]}.
template <typename PerGroup>
void run_grouped(const std::string& test, const an::LongCsv& csv,
                 const std::vector<std::string>& group_columns, bool as_json, PerGroup per_group) {
  const auto groups = split_groups(csv, group_columns);
  json out;
  if (!group_columns.empty()) out = {{"test", test}, {"groups", json::array()}};
  for (const auto& g : groups) {
    if (!as_json && !group_columns.empty()) std::cout << "[" << g.label << "]\n";
    std::string context = group_columns.empty() ? "" : " (group " + g.label + ")";
    json result;
    try {
      result = per_group(g);
    } catch (const an::DataError& e) {
      throw an::DataError(std::string(e.what()) + context);
    }
    if (group_columns.empty()) {
      out = std::move(result);
    } else {
      result["group"] = g.key;
      out["groups"].push_back(std::move(result));
    }
  }
  if (as_json) std::cout << out.dump(2) << "\n";
  std::cout.flush();
}

json test_json(const an::TestResult& r) {
  return {{"test", r.method}, {"statistic", r.statistic}, {"df", r.df},        {"p", r.p},
          {"n", r.observations}, {"blocks", r.blocks},   {"treatments", r.treatments}};
}

void print_test(const an::TestResult& r) {
  std::cout << r.method << ": chi-square = " << num(r.statistic) << ", df = " << num(r.df)
            << ", p = " << num(r.p) << "  (" << r.blocks << " blocks, " << r.treatments
            << " treatments, " << r.observations << " observations)\n";
}

void run_block_test(const CommonOptions& opt, const std::string& test,
                    an::TestResult (*run)(const an::BlockTable&)) {
  const auto csv = read_data(opt.csv, opt.drop_missing, {opt.columns.value});
  const auto observations = an::read_observations(csv, opt.columns);
  run_grouped(test, csv, opt.group, opt.json, [&](const Group& g) {
    const an::TestResult r = run(table_for(csv, observations, g, opt.columns.replicate));
    json j = test_json(r);
    if (test == "friedman") {
      // Replicates per cell: the test needs them equal (friedman.h).
      const std::size_t reps = r.observations / (r.blocks * r.treatments);
      const double w = an::kendalls_w(r.statistic, r.blocks, r.treatments, reps);
      j["kendalls_w"] = w;
      if (!opt.json) {
        print_test(r);
        std::cout << "  effect size: Kendall's W = " << num(w) << " (0: no agreement between blocks, 1: all rank alike)\n";
      }
    } else if (!opt.json) {
      print_test(r);
    }
    return j;
  });
}

void run_durbin(const CommonOptions& opt) {
  const auto csv = read_data(opt.csv, opt.drop_missing, {opt.columns.value});
  const auto observations = an::read_observations(csv, opt.columns);
  run_grouped("durbin", csv, opt.group, opt.json, [&](const Group& g) {
    const an::DurbinResult r = an::durbin_test(table_for(csv, observations, g, opt.columns.replicate));
    if (!opt.json) {
      print_test(r.chi_square);
      std::cout << "  F form: F = " << num(r.f) << ", df = " << num(r.f_df1) << ", "
                << num(r.f_df2) << ", p = " << num(r.f_p) << "\n";
    }
    json j = test_json(r.chi_square);
    j["f"] = {{"statistic", r.f}, {"df1", r.f_df1}, {"df2", r.f_df2}, {"p", r.f_p}};
    return j;
  });
}

// --method participant: each block's median per treatment, its difference
// from the control's, the exact sign-flip test (stats/sign_flip_vs_control.h).
void run_pairwise_by_block(const PairwiseOptions& opt) {
  const auto csv = read_data(opt.common.csv, opt.common.drop_missing, {opt.common.columns.value});
  const auto observations = an::read_observations(csv, opt.common.columns);
  const an::PercentileMethod median_method = an::parse_percentile_method(opt.percentile_method);
  run_grouped("pairwise-sign-flip", csv, opt.common.group, opt.common.json, [&](const Group& g) {
    const an::BlockTable table = table_for(csv, observations, g, opt.common.columns.replicate);
    const std::size_t m = table.treatment_count() - 1;
    const double level = an::sidak_level(opt.alpha, m);
    const auto comparisons = an::sign_flip_vs_control(table, opt.control, level, median_method);
    json j = {{"test", "pairwise-sign-flip"}, {"control", opt.control}, {"alpha", opt.alpha},
              {"m", m},                        {"sidak_level", level},   {"comparisons", json::array()}};
    if (!opt.common.json) {
      std::cout << "Sign-flip permutation test of each block's median difference from " << opt.control
                << " (one value per " << opt.common.columns.block << "); significant when p < " << num(level)
                << " (Sidak, alpha = " << num(opt.alpha) << ", m = " << m << ")\n";
      std::printf("%-24s %7s %14s %12s  %s\n", "treatment", "blocks", "mean diff", "p", "significant");
    }
    for (const auto& c : comparisons) {
      j["comparisons"].push_back({{"treatment", c.treatment},
                                  {"n_blocks", c.blocks},
                                  {"p", c.p ? json(*c.p) : json(nullptr)},
                                  {"mean_difference", c.p ? json(c.mean_difference) : json(nullptr)},
                                  {"significant", c.significant}});
      if (!opt.common.json)
        std::printf("%-24s %7zu %14s %12s  %s\n", c.treatment.c_str(), c.blocks,
                    c.p ? num(c.mean_difference).c_str() : "N/A", c.p ? num(*c.p).c_str() : "N/A",
                    c.p ? (c.significant ? "yes" : "no") : "N/A");
    }
    if (!opt.common.json) {
      std::printf("With n blocks the smallest p is 2/2^n (0.25 for 3, 0.0078 for 8).\n");
      std::fflush(stdout);
    }
    return j;
  });
}

void run_pairwise(const PairwiseOptions& opt) {
  if (opt.method == "participant") return run_pairwise_by_block(opt);
  const auto csv = read_data(opt.common.csv, opt.common.drop_missing, {opt.common.columns.value});
  const auto observations = an::read_observations(csv, opt.common.columns);
  run_grouped("pairwise-friedman", csv, opt.common.group, opt.common.json, [&](const Group& g) {
    const an::BlockTable table = table_for(csv, observations, g, opt.common.columns.replicate);
    const auto comparisons = an::pairwise_friedman_vs_control(table, opt.control, opt.alpha);
    const double level = an::sidak_level(opt.alpha, comparisons.size());
    json j = {{"test", "pairwise-friedman"}, {"control", opt.control}, {"alpha", opt.alpha},
              {"m", comparisons.size()},     {"sidak_level", level},  {"comparisons", json::array()}};
    if (!opt.common.json) {
      std::cout << "Friedman, " << opt.control << " vs each other treatment; significant when p < "
                << num(level) << " (Sidak, alpha = " << num(opt.alpha) << ", m = "
                << comparisons.size() << ")\n";
      std::printf("%-24s %7s %12s %12s  %-11s  %s\n", "treatment", "blocks", "chi-square", "p",
                  "significant", "rank-biserial r");
      std::fflush(stdout);
    }
    for (const auto& c : comparisons) {
      json e = {{"treatment", c.treatment},
                {"statistic", c.statistic ? json(*c.statistic) : json(nullptr)},
                {"df", c.df ? json(*c.df) : json(nullptr)},
                {"p", c.p ? json(*c.p) : json(nullptr)},
                {"n", c.n_observations},
                {"n_blocks", c.n_blocks},
                {"replicates", c.replicates},
                {"dropped_observations", c.dropped_observations},
                {"blocks_left_out", c.blocks_left_out},
                {"significant", c.significant},
                {"rank_biserial", c.rank_biserial ? json(*c.rank_biserial) : json(nullptr)}};
      j["comparisons"].push_back(std::move(e));
      if (!opt.common.json) {
        std::printf("%-24s %7zu %12s %12s  %-11s  %s\n", c.treatment.c_str(), c.n_blocks,
                    c.statistic ? num(*c.statistic).c_str() : "N/A",
                    c.p ? num(*c.p).c_str() : "N/A", c.p ? (c.significant ? "yes" : "no") : "N/A",
                    c.rank_biserial ? num(*c.rank_biserial).c_str() : "N/A");
        std::fflush(stdout);
      }
    }
    if (!opt.common.json) {
      // Balancing keeps the first repetitions; say what each test did not see.
      for (const auto& c : comparisons) {
        if (c.dropped_observations == 0) continue;
        std::cout << "  " << c.treatment << ": "
                  << an::balancing_note(c.replicates, c.dropped_observations, c.blocks_left_out)
                  << "\n";
      }
    }
    return j;
  });
}

void run_correlation(const CorrelationOptions& opt) {
  const auto csv = read_data(opt.csv, opt.drop_missing, {opt.x, opt.y});
  const std::size_t x = csv.column(opt.x);
  const std::size_t y = csv.column(opt.y);
  run_grouped("pearson-correlation", csv, opt.group, opt.json, [&](const Group& g) {
    std::vector<double> xs;
    std::vector<double> ys;
    for (std::size_t r : g.rows) {
      xs.push_back(csv.number(r, x));
      ys.push_back(csv.number(r, y));
    }
    const an::CorrelationResult c = an::pearson_correlation(xs, ys, opt.x, opt.y);
    const std::string strength(an::correlation_strength_name(c.strength));
    if (!opt.json) {
      std::cout << "Pearson r(" << opt.x << ", " << opt.y << ") = " << num(c.r) << ", t = "
                << num(c.t) << ", df = " << num(c.df) << ", p = " << num(c.p) << ", n = " << c.n
                << ", correlation: " << strength << "\n";
    }
    return json{{"test", "pearson-correlation"}, {"r", c.r}, {"statistic", c.t}, {"df", c.df},
                {"p", c.p}, {"n", c.n}, {"strength", strength}};
  });
}

// The KS columns: without --block and without a "block" column the pooled
// test needs no blocks (only the bootstrap resamples per block).
an::LongColumns ks_columns(const KsOptions& opt, const an::LongCsv& csv) {
  an::LongColumns columns = opt.common.columns;
  const bool has_block_column = std::find(csv.columns().begin(), csv.columns().end(),
                                          columns.block) != csv.columns().end();
  if (!opt.block_given && !has_block_column) {
    if (opt.bootstrap > 0) {
      throw an::DataError(opt.common.csv + ": ks --bootstrap needs --block COL naming the "
                          "participant (the file has no column '" + columns.block + "')");
    }
    columns.block.clear();
  }
  return columns;
}

json ks_pooled(const KsOptions& opt, const an::KsSamples& samples) {
  const an::KsResult ks = an::ks_test(samples.control, samples.other);
  const char* p_method = ks.exact ? "exact" : "asymptotic";
  json j = {{"test", "ks"},
            {"control", opt.control},
            {"other", opt.other},
            {"statistic", ks.d},
            {"p", ks.p},
            {"p_method", p_method},  // "exact" below n1*n2 = 10000, else "asymptotic"
            {"p_asymptotic", ks.p_asymptotic},
            {"n", ks.n1 + ks.n2},
            {"n_control", ks.n1},
            {"n_other", ks.n2}};
  if (!opt.common.json) {
    std::cout << "Kolmogorov-Smirnov, pooled " << opt.control << " (n = " << ks.n1 << ") vs "
              << opt.other << " (n = " << ks.n2 << "): D = " << num(ks.d) << ", " << p_method
              << " p = " << num(ks.p) << "\n";
  }
  return j;
}

json ks_bootstrap_result(const KsOptions& opt, const an::KsSamples& samples, an::PercentileMethod method) {
  an::KsBootstrapOptions bo;
  bo.resamples = opt.bootstrap;
  bo.block_length = opt.block_length;
  bo.seed = opt.seed;
  bo.percentile_method = method;
  const an::KsBootstrapResult b = an::ks_block_bootstrap(samples.participants, bo);
  if (!opt.common.json) {
    std::cout << "Moving block bootstrap (" << bo.resamples << " resamples, block length "
              << bo.block_length << ", seed " << bo.seed << ", " << b.participants_used
              << " participants):\n  D_intra 95% range [" << num(b.intra.low) << ", "
              << num(b.intra.high) << "]\n  D_inter 95% range [" << num(b.inter.low) << ", "
              << num(b.inter.high) << "]\n  "
              << (b.significant ? "ranges do not overlap: significant difference"
                                : "ranges overlap: no significant difference")
              << "\n";
  }
  return {{"resamples", bo.resamples},
          {"block_length", bo.block_length},
          {"seed", bo.seed},
          {"percentile_method", std::string(an::percentile_method_name(method))},
          {"participants_used", b.participants_used},
          {"d_intra_95", {b.intra.low, b.intra.high}},
          {"d_inter_95", {b.inter.low, b.inter.high}},
          {"significant", b.significant}};
}

void run_ks(const KsOptions& opt) {
  const auto csv = read_data(opt.common.csv, opt.common.drop_missing, {opt.common.columns.value});
  const an::LongColumns columns = ks_columns(opt, csv);
  // One participant may be enough for the bootstrap (the thesis' "(1)" rows).
  const auto observations = an::read_observations(csv, columns, 1, 2);
  // One treatment against itself was reported as "no rows" of the other.
  if (opt.control == opt.other) {
    throw an::DataError("ks: --control and --other are both '" + opt.control + "'; the test compares two different " +
                        opt.common.columns.treatment + " values");
  }
  if (opt.bootstrap > 0 && opt.common.columns.replicate.empty()) {
    throw an::DataError("ks --bootstrap needs --replicate COL to tell the repetitions apart");
  }
  if (opt.bootstrap > 0 && opt.block_length == 0) {
    throw an::DataError("ks --bootstrap needs --block-length L (samples per block, >= 1)");
  }
  const auto method = an::parse_percentile_method(opt.percentile_method);
  run_grouped("ks", csv, opt.common.group, opt.common.json, [&](const Group& g) {
    const an::KsSamples samples = an::gather_ks_samples(observations, g.rows, opt.control, opt.other,
                                                        opt.common.csv, opt.common.columns.treatment);
    json j = ks_pooled(opt, samples);
    if (opt.bootstrap > 0) j["bootstrap"] = ks_bootstrap_result(opt, samples, method);
    return j;
  });
}

// stats pairwise: its options (the method, the control, alpha).
void add_pairwise_subcommand(CLI::App* stats) {
  auto opt = std::make_shared<PairwiseOptions>();
  CLI::App* cmd = stats->add_subcommand(
      "pairwise",
      "A control against each other treatment, judged at the Sidak level 1-(1-alpha)^(1/m): the thesis' "
      "Friedman test over the blocks holding both (--method thesis), or one value per block, the exact "
      "sign-flip test of the blocks' median differences (--method participant; blocks are participants)");
  add_common_options(*cmd, opt->common, true);
  cmd->add_option("--control", opt->control, "Treatment to compare the others with")
      ->required();
  cmd->add_option("--alpha", opt->alpha, "Family-wise significance level, in (0, 1)")
      ->capture_default_str()
      ->check(CLI::Validator(
          [](const std::string& text) {
            // CLI::Range is closed; 0 and 1 are no significance levels.
            double a = 0.0;
            if (!CLI::detail::lexical_cast(text, a) || !(a > 0.0 && a < 1.0))
              return "alpha is " + text + "; it must lie strictly between 0 and 1";
            return std::string();
          },
          "in (0, 1)"));
  cmd->add_option("--method", opt->method,
                  "thesis: pairwise Friedman, replicates as evidence; participant: each block's median, "
                  "one difference per block, exact sign-flip test (docs/analysis.md, \"Which comparison\")")
      ->capture_default_str()
      ->check(CLI::IsMember({"thesis", "participant"}));
  cmd->add_option("--percentile-method", opt->percentile_method,
                  "Median definition for --method participant: matlab, r7, r6, nearest")
      ->capture_default_str();
  cmd->callback([opt] { run_pairwise(*opt); });
}

// stats ks: its options (the treatments, the bootstrap).
void add_ks_subcommand(CLI::App* stats) {
  auto opt = std::make_shared<KsOptions>();
  CLI::App* cmd = stats->add_subcommand(
      "ks",
      "Two-sample Kolmogorov-Smirnov D of two treatments; with --bootstrap, the thesis' "
      "Appendix I moving block bootstrap of D_intra and D_inter");
  add_common_options(*cmd, opt->common, true);
  cmd->get_option("--block")->description(
      "Column naming the participant; the pooled test needs none (used only when the file has "
      "it), --bootstrap does");
  cmd->add_option("--control", opt->control, "Control treatment (e.g. the High Fidelity setting)")
      ->required();
  cmd->add_option("--other", opt->other, "Treatment compared with the control")->required();
  cmd->add_option("--bootstrap", opt->bootstrap,
                  "Bootstrap resamples (0: only the pooled D and its p, exact when "
                  "n_control * n_other < 10000, else asymptotic; the thesis "
                  "used 1000); needs --replicate and --block-length")
      ->capture_default_str();
  cmd->add_option("--block-length", opt->block_length,
                  "Moving block length in samples (>= 1, at most the shortest repetition); "
                  "cover the autocorrelation of the data");
  add_seed_option(*cmd, opt->seed, "Random seed; the same seed and data give the same ranges");
  cmd->add_option("--percentile-method", opt->percentile_method,
                  "Percentile definition for the 95% ranges: matlab, r7, r6, nearest")
      ->capture_default_str();
  cmd->callback([opt, cmd] {
    opt->block_given = cmd->count("--block") > 0;
    run_ks(*opt);
  });
}

}  // namespace

void add_stats_command(CLI::App& app) {
  CLI::App* stats = app.add_subcommand(
      "stats", "Rank tests, correlation and KS on long-format CSV study data (thesis 3.3.7)");
  stats->require_subcommand(1);
  add_stats_learning_commands(*stats);

  {
    auto opt = std::make_shared<CommonOptions>();
    CLI::App* cmd = stats->add_subcommand(
        "friedman",
        "Friedman test across treatments (replicates ranked within their block, as MATLAB "
        "friedman(x, reps)); complete blocks only");
    add_common_options(*cmd, *opt, true);
    cmd->callback([opt] { run_block_test(*opt, "friedman", an::friedman_test); });
  }
  add_pairwise_subcommand(stats);
  {
    auto opt = std::make_shared<CommonOptions>();
    CLI::App* cmd = stats->add_subcommand(
        "durbin", "Durbin test for a balanced incomplete block design (one value per cell)");
    add_common_options(*cmd, *opt, true);
    cmd->callback([opt] { run_durbin(*opt); });
  }
  {
    auto opt = std::make_shared<CommonOptions>();
    CLI::App* cmd = stats->add_subcommand(
        "skillings-mack", "Skillings-Mack test for block designs with missing cells (one value "
                          "per cell)");
    add_common_options(*cmd, *opt, true);
    cmd->callback([opt] { run_block_test(*opt, "skillings-mack", an::skillings_mack_test); });
  }
  {
    auto opt = std::make_shared<CorrelationOptions>();
    CLI::App* cmd = stats->add_subcommand(
        "correlation",
        "Pearson correlation with two-sided p; |r| >= 0.7 strong, >= 0.3 weak, else none");
    add_csv_option(*cmd, opt->csv);
    cmd->add_option("--x", opt->x, "Column of the first variable (e.g. trial number)")->required();
    cmd->add_option("--y", opt->y, "Column of the second variable (e.g. a performance measure)")
        ->required();
    add_group_option(*cmd, opt->group);
    add_drop_missing_flag(*cmd, opt->drop_missing);
    cmd->add_flag("--json", opt->json, "Print one JSON object instead of a table");
    cmd->callback([opt] { run_correlation(*opt); });
  }
  add_ks_subcommand(stats);
}

}  // namespace hapticlab::app
