// The population fit's posterior (population_fit_parts.h): the novice
// factor's own posterior, the draws and summaries of the free parameters
// that go into the population file, and each calibration target under them.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/common/random.h"
#include "planning/population_fit_parts.h"
#include "protocols/rng.h"

namespace hapticlab::planning::population_fit {

namespace {

// The grid cell's value of a parameter, jittered within the cell.
double jitter(const std::vector<double>& c, std::size_t i, bool log_scale, double u) {
  if (c.size() == 1) return c[0];
  if (log_scale) {
    const double step = std::log(c[1] / c[0]);
    return c[i] * std::exp((u - 0.5) * step);
  }
  const double step = c[1] - c[0];
  return c[i] + (u - 0.5) * step;
}

constexpr std::array<const char*, 4> kFreeNames = {"visual_gain_mean", "consistency_median", "force_level_log_sd",
                                                  "novice_force_factor"};

// The posterior's draws: a grid cell by its posterior, each parameter
// jittered within it, and the novice factor from its own posterior.
std::vector<PopulationParams> posterior_draws(const GridPosterior& gp, const NovicePosterior& novice,
                                              const PopulationFitOptions& o) {
  const GridSpec& grid = gp.grid;
  Random draw_rng = Random::derive(o.seed, protocols::fnv1a64("population fit: posterior draws"));
  std::vector<double> cum(gp.post.size());
  std::partial_sum(gp.post.begin(), gp.post.end(), cum.begin());
  std::vector<double> novice_cum(novice.post.size());
  std::partial_sum(novice.post.begin(), novice.post.end(), novice_cum.begin());
  auto pick = [&](const std::vector<double>& c) {
    const double u = draw_rng.uniform() * c.back();
    return static_cast<std::size_t>(std::min<std::ptrdiff_t>(std::upper_bound(c.begin(), c.end(), u) - c.begin(),
                                                             static_cast<std::ptrdiff_t>(c.size()) - 1));
  };
  constexpr int kSummaryDraws = 4000;
  std::vector<PopulationParams> draws;
  for (int k = 0; k < std::max(kSummaryDraws, o.posterior_draws); ++k) {
    const std::size_t cell = pick(cum);
    const std::size_t jf = cell % grid.force_sd.size();
    const std::size_t ic = (cell / grid.force_sd.size()) % grid.consistency.size();
    const std::size_t ig = cell / (grid.force_sd.size() * grid.consistency.size());
    PopulationParams p = fixed_population();
    p.visual_gain_mean = std::clamp(jitter(grid.gain, ig, false, draw_rng.uniform()), kGridPriors[0].lo, kGridPriors[0].hi);
    p.consistency_median =
        std::clamp(jitter(grid.consistency, ic, true, draw_rng.uniform()), kGridPriors[1].lo, kGridPriors[1].hi);
    p.force_level_log_sd =
        std::clamp(jitter(grid.force_sd, jf, false, draw_rng.uniform()), kGridPriors[2].lo, kGridPriors[2].hi);
    const std::size_t nk = pick(novice_cum);
    p.novice_force_factor = std::clamp(novice.grid[nk] + (draw_rng.uniform() - 0.5) * 0.005, kNoviceLo, kNoviceHi);
    draws.push_back(p);
  }
  return draws;
}

// Free parameter q summarized over the draws: mean, SD, 95 % interval,
// with its prior.
FreeParameter summarize_free(const std::vector<PopulationParams>& draws, int q) {
  std::vector<double> v;
  for (const PopulationParams& d : draws) v.push_back(free_value(d, q));
  std::sort(v.begin(), v.end());
  const double mean = mean_of(v);
  double ss = 0.0;
  for (double x : v) ss += (x - mean) * (x - mean);
  FreeParameter f;
  f.name = kFreeNames[static_cast<std::size_t>(q)];
  if (q < 3) {
    const Prior& pr = kGridPriors[static_cast<std::size_t>(q)];
    f.why = pr.why, f.prior_low = pr.lo, f.prior_high = pr.hi, f.prior_log = pr.log_scale, f.prior_source = pr.source;
  } else {
    f.why = kNoviceWhy, f.prior_low = kNoviceLo, f.prior_high = kNoviceHi, f.prior_source = kNoviceSource;
  }
  f.mean = mean;
  f.sd = std::sqrt(ss / static_cast<double>(v.size() - 1));
  f.low95 = v[static_cast<std::size_t>(0.025 * static_cast<double>(v.size() - 1))];
  f.high95 = v[static_cast<std::size_t>(0.975 * static_cast<double>(v.size() - 1))];
  return f;
}

// An event target's probability, or a value target's model value, over the
// grid's posterior.
TargetDiagnostic grid_target(const GridPosterior& gp, std::size_t t) {
  TargetDiagnostic d;
  d.target = gp.targets[t];
  std::vector<std::pair<double, double>> v;
  for (std::size_t k = 0; k < gp.points.size(); ++k)
    if (gp.post[k] > 0.0) {
      v.push_back({gp.points[k].values[t], gp.post[k]});
      d.mean += gp.post[k] * gp.points[k].values[t];
    }
  d.low95 = weighted_quantile(v, 0.025);
  d.high95 = weighted_quantile(v, 0.975);
  if (d.target.kind == CalibrationTarget::Kind::kEvent) {
    d.met = d.mean >= 0.05;
    if (!d.met)
      d.note = "missed: a study of the source's design has the published outcome with probability " + fmt(d.mean) +
               " [" + fmt(d.low95) + ", " + fmt(d.high95) + "] under the fitted population";
  } else {
    d.met = std::abs(d.mean - d.target.value) <= 1.96 * d.target.sd;
    if (!d.met)
      d.note = "missed: the model's value is " + fmt(d.mean) + " [" + fmt(d.low95) + ", " + fmt(d.high95) +
               "] against " + fmt(d.target.value) + " +- 1.96 x " + fmt(d.target.sd);
  }
  return d;
}

}  // namespace

double free_value(const PopulationParams& p, int q) {
  return q == 0 ? p.visual_gain_mean : q == 1 ? p.consistency_median : q == 2 ? p.force_level_log_sd
                                                                               : p.novice_force_factor;
}

NovicePosterior novice_posterior(const CalibrationTarget& golahmadi, double kappa) {
  NovicePosterior n;
  for (double f = kNoviceLo + 0.0025; f < kNoviceHi; f += 0.005) n.grid.push_back(f);
  double top = -std::numeric_limits<double>::infinity();
  for (double f : n.grid) {
    n.post.push_back(normal_log_density(std::pow(f, kappa), golahmadi.value, golahmadi.sd));
    top = std::max(top, n.post.back());
  }
  double total = 0.0;
  for (double& p : n.post) total += (p = std::exp(p - top));
  for (double& p : n.post) p /= total;
  return n;
}

void draw_population(const GridPosterior& gp, const NovicePosterior& novice, const PopulationFitOptions& o,
                     std::vector<PopulationParams>& draws, PopulationFile& file) {
  draws = posterior_draws(gp, novice, o);
  file.model_version = kParticipantModelVersion;
  file.description =
      "The simulated surgeons' population fitted to the calibration set (docs/simulation.md, \"Fitting the "
      "population\"). Made by: " + (o.command.empty() ? std::string("hapticlab plan calibrate --fit") : o.command);
  file.point = fixed_population();
  for (int q = 0; q < 4; ++q) {
    FreeParameter f = summarize_free(draws, q);
    file.point.set_field(f.name, f.mean);
    file.free.push_back(std::move(f));
  }
  draws.resize(static_cast<std::size_t>(o.posterior_draws));
  file.draws = draws;
  file.fixed = fixed_parameters();
  file.sources = calibration_sources();
  file.targets = calibration_targets();
}

std::vector<TargetDiagnostic> target_diagnostics(const GridPosterior& gp, const std::vector<PopulationParams>& draws,
                                                 double kappa) {
  std::vector<TargetDiagnostic> out;
  for (std::size_t t = 0; t < gp.targets.size(); ++t) out.push_back(grid_target(gp, t));
  TargetDiagnostic d;
  d.target = *gp.golahmadi;
  std::vector<double> v;
  for (const PopulationParams& p : draws) v.push_back(std::pow(p.novice_force_factor, kappa));
  std::sort(v.begin(), v.end());
  d.mean = mean_of(v);
  d.low95 = v[static_cast<std::size_t>(0.025 * static_cast<double>(v.size() - 1))];
  d.high95 = v[static_cast<std::size_t>(0.975 * static_cast<double>(v.size() - 1))];
  d.met = std::abs(d.mean - d.target.value) <= 1.96 * d.target.sd;
  if (!d.met) d.note = "missed: the model's novice/expert ratio is " + fmt(d.mean);
  out.push_back(d);
  return out;
}

}  // namespace hapticlab::planning::population_fit
