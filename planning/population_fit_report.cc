// The population fit's report (population_fit_parts.h): whether it
// converged -- coverage of the posterior by the bank, the emulator's fit,
// enough participants, the Monte Carlo error, a posterior piled at a prior
// bound -- the checks' notes, and the summary and record of the fit.
#include <algorithm>
#include <cmath>

#include "core/common/build_info.h"
#include "planning/population_fit_parts.h"

namespace hapticlab::planning::population_fit {

namespace {

// The emulator against each design population's observed share of each
// thesis outcome (binomial z; the notes name the worst).
void check_emulator(const Bank& bank, PopulationFitResult& result) {
  const int D = static_cast<int>(bank.designs.size());
  const std::vector<double> ones(bank.studies.size(), 1.0);
  const Emulator emulator = fit_emulator(bank, ones);
  double worst_z = 0.0;
  std::string worst;
  for (int e = 0; e < kThesisEvents; ++e)
    for (int d = 0; d < D; ++d) {
      double observed = 0.0, predicted = 0.0;
      int n = 0;
      for (const StudyData& st : bank.studies) {
        if (st.design != d) continue;
        observed += st.outcome[static_cast<std::size_t>(e)] ? 1.0 : 0.0;
        predicted += predict(emulator[static_cast<std::size_t>(e)], features(st.mean_gain, st.mean_log_consistency));
        ++n;
      }
      if (n == 0) continue;
      const double p = std::clamp(predicted / n, 0.5 / n, 1.0 - 0.5 / n);
      const double z = (observed - predicted) / std::sqrt(n * p * (1.0 - p));
      if (std::abs(z) > std::abs(worst_z)) {
        worst_z = z;
        worst = std::string(kThesisTargetIds[static_cast<std::size_t>(e)]) + " at design population " +
                std::to_string(d + 1) + " (visual gain " + fmt(bank.designs[static_cast<std::size_t>(d)].visual_gain_mean) +
                ", consistency " + fmt(bank.designs[static_cast<std::size_t>(d)].consistency_median) + "): observed " +
                fmt(observed) + " of " + std::to_string(n) + ", emulated " + fmt(predicted);
      }
    }
  result.notes.push_back("thesis emulator: largest misfit to a design population's studies z = " + fmt(worst_z) +
                         ", " + worst + " (of " + std::to_string(kThesisEvents * D) + " checks)");
  if (std::abs(worst_z) > 4.0)
    result.problems.push_back("the thesis emulator does not fit the bank: " + worst + " (z = " + fmt(worst_z) +
                              ")");
  result.summary["emulator_worst_z"] = worst_z;
}

// Grid parameter q: the Monte Carlo error of its posterior mean (a problem
// when more than half its posterior SD), and a posterior that piles up at
// a prior bound (a target the model cannot reach inside its prior: a note).
// Returns the Monte Carlo SD.
double check_parameter(const GridPosterior& gp, const std::vector<PopulationParams>& draws,
                       const PopulationFitOptions& o, int q, PopulationFitResult& result) {
  const auto& bm = gp.boot_means[static_cast<std::size_t>(q)];
  double mcsd = 0.0;
  if (bm.size() > 1) {
    const double m = mean_of(bm);
    for (double x : bm) mcsd += (x - m) * (x - m);
    mcsd = std::sqrt(mcsd / static_cast<double>(bm.size() - 1));
  }
  const FreeParameter& f = result.file.free[static_cast<std::size_t>(q)];
  if (o.bootstrap > 1 && mcsd > 0.5 * f.sd)
    result.problems.push_back("the Monte Carlo error of " + f.name + "'s posterior mean is " + fmt(mcsd) +
                              ", more than half its posterior SD (" + fmt(f.sd) +
                              "): more studies per design point (--fit-studies)");
  const Prior& pr = kGridPriors[static_cast<std::size_t>(q)];
  const double edge = (pr.log_scale ? std::log(pr.hi / pr.lo) : pr.hi - pr.lo) / pr.cells;
  auto near = [&](double v, double bound) {
    return (pr.log_scale ? std::abs(std::log(v / bound)) : std::abs(v - bound)) < edge;
  };
  double low_mass = 0.0, high_mass = 0.0;
  for (const PopulationParams& d : draws) {
    const double v = free_value(d, q);
    low_mass += near(v, pr.lo) ? 1.0 : 0.0;
    high_mass += near(v, pr.hi) ? 1.0 : 0.0;
  }
  low_mass /= static_cast<double>(draws.size()), high_mass /= static_cast<double>(draws.size());
  if (low_mass > 0.25 || high_mass > 0.25)
    result.notes.push_back(f.name + ": " + fmt(100.0 * std::max(low_mass, high_mass), 2) +
                           " % of the posterior lies in the prior's last cell at " +
                           fmt(low_mass > high_mass ? pr.lo : pr.hi) +
                           ": the targets pull beyond what the prior allows (named, not widened)");
  return mcsd;
}

}  // namespace

void check_convergence(const Bank& bank, const GridPosterior& gp, const std::vector<PopulationParams>& draws,
                       const PopulationFitOptions& o, PopulationFitResult& result) {
  // Coverage of the posterior by the bank.
  double uncovered = 0.0, ess_p_min = 1e300, inside_min = 1e300;
  for (std::size_t k = 0; k < gp.points.size(); ++k) {
    const bool covered = gp.points[k].ess_participants >= 30.0 && gp.points[k].synthetic_inside >= 0.95;
    if (!covered) uncovered += gp.post[k];
    if (gp.post[k] > 1e-3) {
      ess_p_min = std::min(ess_p_min, gp.points[k].ess_participants);
      inside_min = std::min(inside_min, gp.points[k].synthetic_inside);
    }
  }
  check_emulator(bank, result);
  int valid = 0;
  for (const ParticipantData& p : bank.participants) valid += p.valid ? 1 : 0;
  if (valid < 30)
    result.problems.push_back("only " + std::to_string(valid) + " simulated participants completed both High Fidelity "
                              "and No Force Feedback dissection trials (at least 30 are needed): more studies per "
                              "design point (--fit-studies)");
  if (uncovered > 0.05)
    result.problems.push_back("the bank does not cover the posterior: " + fmt(100.0 * uncovered, 2) +
                              " % of its mass lies where fewer than 30 participants carry the weights or more than 5 % "
                              "of a population's studies fall outside the bank's (smallest where it has mass: " +
                              fmt(ess_p_min) + " effective participants, " + fmt(100.0 * inside_min, 3) +
                              " % of studies inside); more studies per design point (--fit-studies)");
  nlohmann::json mc = nlohmann::json::object();
  for (int q = 0; q < 3; ++q) mc[result.file.free[static_cast<std::size_t>(q)].name] = check_parameter(gp, draws, o, q, result);
  result.converged = result.problems.empty();
  nlohmann::json& s = result.summary;
  s["participants_with_both_settings"] = valid;
  s["smallest_effective_participants"] = ess_p_min;
  s["smallest_share_of_studies_inside_the_bank"] = inside_min;
  s["posterior_mass_uncovered"] = uncovered;
  s["monte_carlo_sd_of_posterior_means"] = mc;
}

void report_checks(const BankChecks& c, const PopulationFitOptions& o, PopulationFitResult& result) {
  const auto [rate_mean, rate_mean_se] = mean_and_se(c.d_mean);
  const auto [rate_peak, rate_peak_se] = mean_and_se(c.d_peak);
  const auto [rate_time, rate_time_se] = mean_and_se(c.d_time);
  const auto [rate_level, rate_level_se] = mean_and_se(c.d_level);
  result.notes.push_back("rate check (" + std::to_string(c.d_mean.size()) + " participants at " + fmt(o.rate_Hz) +
                         " Hz and 1 kHz, same seeds): 1 kHz minus bank rate, log No Force Feedback / High Fidelity "
                         "ratio of mean force " + fmt(rate_mean) + " +- " + fmt(rate_mean_se) + " (SE), of peak force " +
                         fmt(rate_peak) + " +- " + fmt(rate_peak_se) + ", of completion time " + fmt(rate_time) +
                         " +- " + fmt(rate_time_se) + "; log High Fidelity mean force " + fmt(rate_level) + " +- " +
                         fmt(rate_level_se) + "; thesis outcomes the same in " + std::to_string(c.rate_events_same) +
                         " of " + std::to_string(c.rate_events));
  result.notes.push_back("novice check (" + std::to_string(c.d_novice.size()) +
                         " participants as novices with factor 1.227, same seeds): log ratio of the High Fidelity mean "
                         "force " + fmt(c.novice_log_ratio) + " +- " + fmt(c.novice_se) + " (SE), log 1.227 = " +
                         fmt(std::log(1.227)) + ": forces scale with the force level as level^" + fmt(c.kappa));
  nlohmann::json& s = result.summary;
  s["kappa_force_level_exponent"] = c.kappa;
  s["rate_check"] = {{"participants", c.d_mean.size()},
                     {"log_ratio_mean_force_difference", rate_mean}, {"se_mean", rate_mean_se},
                     {"log_ratio_peak_force_difference", rate_peak}, {"se_peak", rate_peak_se},
                     {"log_ratio_time_difference", rate_time}, {"se_time", rate_time_se},
                     {"log_hf_mean_force_difference", rate_level}, {"se_level", rate_level_se},
                     {"thesis_outcomes_same", c.rate_events_same}, {"thesis_outcomes", c.rate_events}};
}

void summarize(const protocols::Protocol& protocol, const Bank& bank, const GridPosterior& gp,
               const PopulationFitOptions& o, const FitTimes& times, PopulationFitResult& result) {
  // Posterior-mean population ratios, for the report.
  double rm = 0.0, rp = 0.0, rt = 0.0;
  std::vector<std::pair<double, double>> vm, vp, vt;
  for (std::size_t k = 0; k < gp.points.size(); ++k) {
    rm += gp.post[k] * gp.points[k].ratio_mean, rp += gp.post[k] * gp.points[k].ratio_peak,
        rt += gp.post[k] * gp.points[k].ratio_time;
    vm.push_back({gp.points[k].ratio_mean, gp.post[k]}), vp.push_back({gp.points[k].ratio_peak, gp.post[k]});
    vt.push_back({gp.points[k].ratio_time, gp.post[k]});
  }
  nlohmann::json& s = result.summary;
  s["design_populations"] = static_cast<int>(bank.designs.size());
  s["studies_per_design_point"] = o.studies_per_design_point;
  s["studies"] = bank.studies.size();
  s["participants"] = bank.participants.size();
  s["trials_run"] = bank.trials_run;
  s["trials_timed_out"] = bank.trials_timed_out;
  s["rate_hz"] = o.rate_Hz;
  s["grid_points"] = gp.points.size();
  s["population_ratios_no_feedback_over_high_fidelity"] = {
      {"mean_force", {rm, weighted_quantile(vm, 0.025), weighted_quantile(vm, 0.975)}},
      {"peak_force", {rp, weighted_quantile(vp, 0.025), weighted_quantile(vp, 0.975)}},
      {"completion_time", {rt, weighted_quantile(vt, 0.025), weighted_quantile(vt, 0.975)}}};
  s["seconds"] = times.seconds;
  s["seconds_bank"] = times.bank_s;
  s["seconds_checks"] = times.checks_s;
  s["seconds_posterior"] = times.seconds - times.bank_s - times.checks_s;

  nlohmann::json fit;
  fit["method"] =
      "simulation-based likelihood on a prior grid (docs/simulation.md, \"Fitting the population\"): a bank of "
      "simulated 3-surgeon studies of the thesis' design at 9 design populations (common random numbers); "
      "participant-level targets by importance weights of each grid population's trait densities over the design "
      "mixture, the thesis' study-level targets by a logistic emulator of each outcome on the studies' mean visual "
      "gain and log consistency; composite likelihood of the calibration set (event targets: probability of the "
      "published outcome in a study of the source's design and size; value targets: Normal); uniform priors; "
      "posterior on the grid, draws jittered within cells; Monte Carlo error by a bootstrap of the bank's studies";
  fit["command"] = o.command;
  fit["seed"] = o.seed;
  fit["rate_hz"] = o.rate_Hz;
  fit["max_trial_s"] = o.max_trial_s;
  fit["studies_per_design_point"] = o.studies_per_design_point;
  fit["protocol"] = protocol.study;
  fit["software"] = software_version();  // "hapticlab X (commit Y)"
  fit["converged"] = result.converged;
  fit["problems"] = result.problems;
  fit["notes"] = result.notes;
  fit["summary"] = s;
  nlohmann::json diag = nlohmann::json::array();
  for (const TargetDiagnostic& d : result.targets)
    diag.push_back({{"id", d.target.id}, {"mean", d.mean}, {"interval95", {d.low95, d.high95}}, {"met", d.met},
                    {"note", d.note}});
  fit["targets"] = diag;
  result.file.fit = fit;
}

}  // namespace hapticlab::planning::population_fit
