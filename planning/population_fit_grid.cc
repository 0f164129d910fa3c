// The population fit's grid (population_fit_parts.h): the thesis targets'
// emulator, every grid population evaluated on the bank (importance weights,
// synthetic studies), the posterior, and its bootstrap over the bank.
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/common/random.h"
#include "planning/population_fit_parts.h"
#include "protocols/rng.h"

namespace hapticlab::planning::population_fit {

// --- the thesis targets' emulator ----------------------------------------------
//
// Whether a 3-surgeon study reproduces a thesis finding depends on its
// three simulated surgeons; importance weights of three people at once
// degenerate (their product varies far more than one person's). So each
// thesis event is emulated: a logistic regression of the bank studies'
// outcomes on the participants' mean visual gain and mean log consistency
// (with their product), fitted with a small ridge (1e-3) against separation.
// A population's probability of the event is then the mean prediction over
// synthetic studies whose participants are drawn from that population
// (common random numbers). Its fit is checked against each design
// population's observed share (notes), and a population whose studies fall
// outside the bank's features is counted as not covered.

namespace {

double logistic(double z) { return 1.0 / (1.0 + std::exp(-z)); }

// Solves A x = b (kEmulatorTerms square, symmetric positive definite) by
// Gaussian elimination with partial pivoting.
Features solve(std::array<Features, kEmulatorTerms> A, Features b) {
  constexpr int n = kEmulatorTerms;
  for (int c = 0; c < n; ++c) {
    int pivot = c;
    for (int r = c + 1; r < n; ++r)
      if (std::abs(A[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)]) >
          std::abs(A[static_cast<std::size_t>(pivot)][static_cast<std::size_t>(c)]))
        pivot = r;
    std::swap(A[static_cast<std::size_t>(c)], A[static_cast<std::size_t>(pivot)]);
    std::swap(b[static_cast<std::size_t>(c)], b[static_cast<std::size_t>(pivot)]);
    const double d = A[static_cast<std::size_t>(c)][static_cast<std::size_t>(c)];
    if (std::abs(d) < 1e-300) continue;
    for (int r = 0; r < n; ++r) {
      if (r == c) continue;
      const double f = A[static_cast<std::size_t>(r)][static_cast<std::size_t>(c)] / d;
      for (int k = 0; k < n; ++k)
        A[static_cast<std::size_t>(r)][static_cast<std::size_t>(k)] -= f * A[static_cast<std::size_t>(c)][static_cast<std::size_t>(k)];
      b[static_cast<std::size_t>(r)] -= f * b[static_cast<std::size_t>(c)];
    }
  }
  Features x{};
  for (int c = 0; c < n; ++c) {
    const double d = A[static_cast<std::size_t>(c)][static_cast<std::size_t>(c)];
    x[static_cast<std::size_t>(c)] = std::abs(d) < 1e-300 ? 0.0 : b[static_cast<std::size_t>(c)] / d;
  }
  return x;
}

// Ridge-penalized logistic regression by Newton's method (IRLS).
Features fit_logistic(const std::vector<Features>& x, const std::vector<bool>& y, const std::vector<double>& weight) {
  constexpr double kRidge = 1e-3;
  Features beta{};
  for (int iteration = 0; iteration < 50; ++iteration) {
    std::array<Features, kEmulatorTerms> H{};
    Features g{};
    for (std::size_t i = 0; i < x.size(); ++i) {
      if (weight[i] <= 0.0) continue;
      const double p = predict(beta, x[i]);
      const double r = (y[i] ? 1.0 : 0.0) - p;
      for (int a = 0; a < kEmulatorTerms; ++a) {
        g[static_cast<std::size_t>(a)] += weight[i] * r * x[i][static_cast<std::size_t>(a)];
        for (int b = 0; b < kEmulatorTerms; ++b)
          H[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)] +=
              weight[i] * p * (1.0 - p) * x[i][static_cast<std::size_t>(a)] * x[i][static_cast<std::size_t>(b)];
      }
    }
    for (int a = 0; a < kEmulatorTerms; ++a) {
      H[static_cast<std::size_t>(a)][static_cast<std::size_t>(a)] += kRidge;
      g[static_cast<std::size_t>(a)] -= kRidge * beta[static_cast<std::size_t>(a)];
    }
    const Features step = solve(H, g);
    double largest = 0.0;
    for (int a = 0; a < kEmulatorTerms; ++a) {
      beta[static_cast<std::size_t>(a)] += step[static_cast<std::size_t>(a)];
      largest = std::max(largest, std::abs(step[static_cast<std::size_t>(a)]));
    }
    if (largest < 1e-9) break;
  }
  return beta;
}

}  // namespace

Features features(double mean_gain, double mean_log_consistency) {
  return {1.0, mean_gain, mean_log_consistency, mean_gain * mean_log_consistency};
}

double predict(const Features& beta, const Features& x) {
  double z = 0.0;
  for (int k = 0; k < kEmulatorTerms; ++k) z += beta[static_cast<std::size_t>(k)] * x[static_cast<std::size_t>(k)];
  return logistic(z);
}

Emulator fit_emulator(const Bank& bank, const std::vector<double>& study_weight) {
  std::vector<Features> x;
  for (const StudyData& s : bank.studies) x.push_back(features(s.mean_gain, s.mean_log_consistency));
  Emulator e{};
  for (int k = 0; k < kThesisEvents; ++k) {
    std::vector<bool> y;
    for (const StudyData& s : bank.studies) y.push_back(s.outcome[static_cast<std::size_t>(k)]);
    e[static_cast<std::size_t>(k)] = fit_logistic(x, y, study_weight);
  }
  return e;
}

SyntheticStudies::SyntheticStudies(std::uint64_t seed, int per_study) : participants(per_study) {
  Random r = Random::derive(seed, protocols::fnv1a64("population fit: synthetic thesis studies"));
  for (int k = 0; k < kSyntheticStudies * per_study; ++k) uniforms.push_back({r.uniform(), r.uniform()});
}

std::vector<Features> SyntheticStudies::of(const PopulationParams& p) const {
  std::vector<Features> out;
  for (int s = 0; s < kSyntheticStudies; ++s) {
    double g = 0.0, l = 0.0;
    for (int i = 0; i < participants; ++i) {
      const auto& u = uniforms[static_cast<std::size_t>(s * participants + i)];
      g += draw_visual_gain(u[0], p) / participants;
      l += std::log(draw_consistency(u[1], p)) / participants;
    }
    out.push_back(features(g, l));
  }
  return out;
}

// --- evaluating the grid ---------------------------------------------------------

Crn::Crn(std::uint64_t seed) {
  Random r = Random::derive(seed, protocols::fnv1a64("population fit: wagner studies"));
  for (int k = 0; k < kWagnerStudies * kWagnerParticipants; ++k) {
    pick.push_back(r.uniform());
    level.push_back(r.uniform());
  }
}

double normal_log_density(double x, double mean, double sd) {
  const double z = (x - mean) / sd;
  return -0.5 * z * z - std::log(sd * std::sqrt(2.0 * 3.14159265358979323846));
}

namespace {

constexpr double kT975_19 = 2.093;  // two-sided 0.05 critical t, 19 degrees of freedom

double kish(const std::vector<double>& w) {
  double s = 0.0, s2 = 0.0;
  for (double x : w) s += x, s2 += x * x;
  return s2 > 0.0 ? s * s / s2 : 0.0;
}

// The bank's feature box (of the studies with weight): synthetic studies
// outside it are extrapolated.
struct FeatureBox {
  double g_lo = 1e300, g_hi = -1e300, l_lo = 1e300, l_hi = -1e300;
};

FeatureBox feature_box(const Bank& bank, const std::vector<double>& study_weight) {
  FeatureBox b;
  for (std::size_t s = 0; s < bank.studies.size(); ++s) {
    if (study_weight[s] <= 0.0) continue;
    b.g_lo = std::min(b.g_lo, bank.studies[s].mean_gain), b.g_hi = std::max(b.g_hi, bank.studies[s].mean_gain);
    b.l_lo = std::min(b.l_lo, bank.studies[s].mean_log_consistency);
    b.l_hi = std::max(b.l_hi, bank.studies[s].mean_log_consistency);
  }
  return b;
}

// The bank's participants weighted for one grid population (valid ones:
// the Wagner and Bergholz targets): w[i], with the CDF over those with
// weight, for drawing synthetic Wagner studies.
struct ParticipantWeights {
  std::vector<double> participant_log_p, lw, w, cdf;
  std::vector<int> valid_index;
  double total = 0.0;

  explicit ParticipantWeights(std::size_t np) : participant_log_p(np), lw(np), w(np) {}

  void weigh(const Bank& bank, const std::vector<double>& study_weight, const PopulationParams& theta) {
    const std::size_t np = bank.participants.size();
    for (std::size_t i = 0; i < np; ++i)
      participant_log_p[i] = log_trait_density(theta, bank.participants[i].gain, bank.participants[i].consistency);
    double top = -std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < np; ++i) {
      lw[i] = participant_log_p[i] - bank.log_q_participant[i];
      if (bank.participants[i].valid && study_weight[static_cast<std::size_t>(bank.participants[i].study)] > 0.0)
        top = std::max(top, lw[i]);
    }
    valid_index.clear();
    cdf.clear();
    total = 0.0;
    for (std::size_t i = 0; i < np; ++i) {
      const double m = study_weight[static_cast<std::size_t>(bank.participants[i].study)];
      w[i] = bank.participants[i].valid && m > 0.0 && std::isfinite(top) ? m * std::exp(lw[i] - top) : 0.0;
      if (w[i] > 0.0) {
        total += w[i];
        valid_index.push_back(static_cast<int>(i));
        cdf.push_back(total);
      }
    }
  }
};

// Weighted moments of the participants' values.
struct Moments {
  double Ea, Eb, Ea2, Eb2, EA, EB, EA2, EB2, EtH, EtN, EtH2, EtN2;
};

Moments moments(const Bank& bank, const ParticipantWeights& pw) {
  auto moment = [&](auto get, int power) {
    double s = 0.0;
    for (int i : pw.valid_index)
      s += pw.w[static_cast<std::size_t>(i)] * std::pow(get(bank.participants[static_cast<std::size_t>(i)]), power);
    return s / pw.total;
  };
  Moments m;
  m.Ea = moment([](const ParticipantData& p) { return p.a; }, 1);
  m.Eb = moment([](const ParticipantData& p) { return p.b; }, 1);
  m.Ea2 = moment([](const ParticipantData& p) { return p.a; }, 2);
  m.Eb2 = moment([](const ParticipantData& p) { return p.b; }, 2);
  m.EA = moment([](const ParticipantData& p) { return p.A; }, 1);
  m.EB = moment([](const ParticipantData& p) { return p.B; }, 1);
  m.EA2 = moment([](const ParticipantData& p) { return p.A; }, 2);
  m.EB2 = moment([](const ParticipantData& p) { return p.B; }, 2);
  m.EtH = moment([](const ParticipantData& p) { return p.tH; }, 1);
  m.EtN = moment([](const ParticipantData& p) { return p.tN; }, 1);
  m.EtH2 = moment([](const ParticipantData& p) { return p.tH; }, 2);
  m.EtN2 = moment([](const ParticipantData& p) { return p.tN; }, 2);
  return m;
}

// The thesis targets: the emulator over a population's synthetic studies;
// `covered_share` gets the share of them inside the bank's features.
std::array<double, kThesisEvents> thesis_probabilities(const Emulator& emulator, const std::vector<Features>& studies,
                                                       const FeatureBox& box, double& covered_share) {
  std::array<double, kThesisEvents> thesis{};
  int inside = 0;
  for (const Features& x : studies) {
    for (int e = 0; e < kThesisEvents; ++e)
      thesis[static_cast<std::size_t>(e)] += predict(emulator[static_cast<std::size_t>(e)], x) / studies.size();
    inside += x[1] >= box.g_lo && x[1] <= box.g_hi && x[2] >= box.l_lo && x[2] <= box.l_hi ? 1 : 0;
  }
  covered_share = static_cast<double>(inside) / static_cast<double>(studies.size());
  return thesis;
}

// Synthetic 20-participant Wagner studies drawn from the weighted bank,
// each participant's forces scaled by its force level: how many found No
// Force Feedback's mean force 1.5 times, its peak force 2 times High
// Fidelity's, and its completion time not significantly different.
struct WagnerHits {
  int mean_hits = 0, peak_hits = 0, time_not_significant = 0;
};

WagnerHits wagner_studies(const Bank& bank, const ParticipantWeights& pw, const Crn& crn,
                          const std::vector<double>& level) {
  WagnerHits h;
  if (pw.valid_index.empty()) return h;
  for (int b = 0; b < kWagnerStudies; ++b) {
    double sa = 0.0, sb = 0.0, sA = 0.0, sB = 0.0, sd = 0.0, sd2 = 0.0;
    for (int j = 0; j < kWagnerParticipants; ++j) {
      const std::size_t k = static_cast<std::size_t>(b * kWagnerParticipants + j);
      const double u = crn.pick[k] * pw.total;
      const auto at = std::upper_bound(pw.cdf.begin(), pw.cdf.end(), u) - pw.cdf.begin();
      const ParticipantData& p =
          bank.participants[static_cast<std::size_t>(pw.valid_index[static_cast<std::size_t>(
              std::min<std::ptrdiff_t>(at, static_cast<std::ptrdiff_t>(pw.cdf.size()) - 1))])];
      const double F = level[k];
      sa += F * p.a, sb += F * p.b, sA += F * p.A, sB += F * p.B;
      const double d = p.log_tN - p.log_tH;
      sd += d, sd2 += d * d;
    }
    h.mean_hits += sb >= 1.5 * sa ? 1 : 0;
    h.peak_hits += sB >= 2.0 * sA ? 1 : 0;
    const double n = kWagnerParticipants;
    const double var = (sd2 - sd * sd / n) / (n - 1.0);
    const double t = var > 0.0 ? (sd / n) / std::sqrt(var / n) : 0.0;
    h.time_not_significant += std::abs(t) < kT975_19 ? 1 : 0;
  }
  return h;
}

// One grid point's target values and log-likelihood, from the weighted
// moments (Bergholz's g, with the force level's spread force_sd), the
// Wagner studies and the thesis probabilities.
void point_values(PointResult& r, const std::vector<CalibrationTarget>& targets, const Moments& m, double force_sd,
                  const WagnerHits& h, const std::array<double, kThesisEvents>& thesis) {
  const auto smooth = [](int hits) { return (hits + 0.5) / (kWagnerStudies + 1.0); };
  // Bergholz's g from the weighted moments and the force level's.
  const double s2 = force_sd * force_sd;
  const double m1 = std::exp(0.5 * s2), m2 = std::exp(2.0 * s2);
  auto g_scaled = [&](double e1, double e1sq, double e2, double e2sq) {
    const double v1 = m2 * e1sq - m1 * m1 * e1 * e1, v2 = m2 * e2sq - m1 * m1 * e2 * e2;
    return m1 * (e2 - e1) / std::sqrt(std::max(1e-300, 0.5 * (v1 + v2)));
  };
  const double g_mean = g_scaled(m.Ea, m.Ea2, m.Eb, m.Eb2);
  const double g_peak = g_scaled(m.EA, m.EA2, m.EB, m.EB2);
  const double g_time =
      (m.EtN - m.EtH) / std::sqrt(std::max(1e-300, 0.5 * ((m.EtH2 - m.EtH * m.EtH) + (m.EtN2 - m.EtN * m.EtN))));
  r.ratio_mean = m.Eb / m.Ea;
  r.ratio_peak = m.EB / m.EA;
  r.ratio_time = m.EtN / m.EtH;
  for (const CalibrationTarget& t : targets) {
    double v = kNaN;
    if (t.id == "wagner_mean_force") v = smooth(h.mean_hits);
    else if (t.id == "wagner_peak_force") v = smooth(h.peak_hits);
    else if (t.id == "wagner_speed") v = smooth(h.time_not_significant);
    else if (t.id == "bergholz_mean_force") v = g_mean;
    else if (t.id == "bergholz_peak_force") v = g_peak;
    else if (t.id == "bergholz_time") v = g_time;
    else
      for (int e = 0; e < kThesisEvents; ++e)
        if (t.id == kThesisTargetIds[static_cast<std::size_t>(e)]) v = thesis[static_cast<std::size_t>(e)];
    r.values.push_back(v);
    if (!std::isfinite(v)) r.log_likelihood = -std::numeric_limits<double>::infinity();
    else if (t.kind == CalibrationTarget::Kind::kEvent) r.log_likelihood += std::log(v);
    else r.log_likelihood += normal_log_density(v, t.value, t.sd);
  }
}

// Every grid point evaluated on the bank; study_weight[s]: multiplicity of
// study s (1 each; a bootstrap resample's counts).
std::vector<PointResult> evaluate_grid(const Bank& bank, const std::vector<double>& study_weight,
                                       const GridSpec& grid, const Crn& crn,
                                       const std::vector<CalibrationTarget>& targets,
                                       const std::vector<std::vector<Features>>& synthetic) {
  const Emulator emulator = fit_emulator(bank, study_weight);
  const FeatureBox box = feature_box(bank, study_weight);
  std::vector<PointResult> out(grid.size());
  // The synthetic studies' force levels, per force-level spread of the grid.
  std::vector<std::vector<double>> levels_of(grid.force_sd.size());
  for (std::size_t jf = 0; jf < grid.force_sd.size(); ++jf) {
    PopulationParams levels = fixed_population();
    levels.force_level_log_sd = grid.force_sd[jf];
    for (const double u : crn.level) levels_of[jf].push_back(draw_force_level(u, false, levels));
  }
  ParticipantWeights pw(bank.participants.size());
  for (std::size_t ig = 0; ig < grid.gain.size(); ++ig)
    for (std::size_t ic = 0; ic < grid.consistency.size(); ++ic) {
      PopulationParams theta = fixed_population();
      theta.visual_gain_mean = grid.gain[ig];
      theta.consistency_median = grid.consistency[ic];
      pw.weigh(bank, study_weight, theta);
      const Moments m = moments(bank, pw);
      const double ess_p = kish(pw.w);
      double covered_share = 0.0;
      const std::array<double, kThesisEvents> thesis =
          thesis_probabilities(emulator, synthetic[ig * grid.consistency.size() + ic], box, covered_share);
      for (std::size_t jf = 0; jf < grid.force_sd.size(); ++jf) {
        PointResult& r = out[grid.index(ig, ic, jf)];
        r.ess_participants = ess_p;
        r.synthetic_inside = covered_share;
        const WagnerHits h = wagner_studies(bank, pw, crn, levels_of[jf]);
        point_values(r, targets, m, grid.force_sd[jf], h, thesis);
      }
    }
  return out;
}

std::vector<double> posterior_of(const std::vector<PointResult>& points) {
  double top = -std::numeric_limits<double>::infinity();
  for (const PointResult& p : points) top = std::max(top, p.log_likelihood);
  std::vector<double> post(points.size(), 0.0);
  double total = 0.0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    post[k] = std::isfinite(points[k].log_likelihood) ? std::exp(points[k].log_likelihood - top) : 0.0;
    total += post[k];
  }
  for (double& p : post) p = total > 0.0 ? p / total : 0.0;
  return post;
}

}  // namespace

// Weighted quantile of values (pairs of value, weight).
double weighted_quantile(std::vector<std::pair<double, double>> v, double q) {
  std::sort(v.begin(), v.end());
  double total = 0.0;
  for (const auto& x : v) total += x.second;
  double acc = 0.0;
  for (const auto& x : v) {
    acc += x.second;
    if (acc >= q * total) return x.first;
  }
  return v.empty() ? kNaN : v.back().first;
}

GridPosterior grid_posterior(const Bank& bank, int participants, const PopulationFitOptions& o,
                             const Progress& progress, const Stop& stop) {
  GridPosterior gp;
  GridSpec& grid = gp.grid;
  grid.gain = centres(kGridPriors[0].lo, kGridPriors[0].hi, kGridPriors[0].cells, kGridPriors[0].log_scale);
  grid.consistency = centres(kGridPriors[1].lo, kGridPriors[1].hi, kGridPriors[1].cells, kGridPriors[1].log_scale);
  grid.force_sd = centres(kGridPriors[2].lo, kGridPriors[2].hi, kGridPriors[2].cells, kGridPriors[2].log_scale);
  for (const CalibrationTarget& t : calibration_targets()) {
    if (t.id == "golahmadi_expertise") gp.golahmadi = &t;
    else gp.targets.push_back(t);
  }
  const Crn crn(o.seed);
  if (progress) progress("posterior on the grid", 0, 1 + o.bootstrap);
  const SyntheticStudies synthetic_draws(o.seed, participants);
  std::vector<std::vector<Features>> synthetic;
  for (const double gain : grid.gain)
    for (const double consistency : grid.consistency) {
      PopulationParams p = fixed_population();
      p.visual_gain_mean = gain;
      p.consistency_median = consistency;
      synthetic.push_back(synthetic_draws.of(p));
    }
  const std::vector<double> ones(bank.studies.size(), 1.0);
  gp.points = evaluate_grid(bank, ones, grid, crn, gp.targets, synthetic);
  gp.post = posterior_of(gp.points);

  auto marginal_mean = [&](const std::vector<double>& p, int which) {
    double m = 0.0;
    for (std::size_t ig = 0; ig < grid.gain.size(); ++ig)
      for (std::size_t ic = 0; ic < grid.consistency.size(); ++ic)
        for (std::size_t jf = 0; jf < grid.force_sd.size(); ++jf) {
          const double v = which == 0 ? grid.gain[ig] : which == 1 ? grid.consistency[ic] : grid.force_sd[jf];
          m += p[grid.index(ig, ic, jf)] * v;
        }
    return m;
  };
  Random r = Random::derive(o.seed, protocols::fnv1a64("population fit: bootstrap"));
  for (int b = 0; b < o.bootstrap; ++b) {
    std::vector<double> counts(bank.studies.size(), 0.0);
    for (std::size_t s = 0; s < bank.studies.size(); ++s)
      counts[static_cast<std::size_t>(r.next_u64() % bank.studies.size())] += 1.0;
    const std::vector<double> pb = posterior_of(evaluate_grid(bank, counts, grid, crn, gp.targets, synthetic));
    for (int q = 0; q < 3; ++q) gp.boot_means[static_cast<std::size_t>(q)].push_back(marginal_mean(pb, q));
    if (progress) progress("posterior on the grid", b + 2, 1 + o.bootstrap);
    if (stop && stop()) throw std::runtime_error("interrupted; nothing written (run it again)");
  }
  return gp;
}

}  // namespace hapticlab::planning::population_fit
