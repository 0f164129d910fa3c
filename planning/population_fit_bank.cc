// The population fit's bank (population_fit_parts.h): simulated studies of
// the thesis' design at each design population, what the fit reads of each
// participant and study, and the rate and novice checks.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <map>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <thread>

#include "planning/population_fit_parts.h"
#include "planning/power.h"
#include "planning/simulated_study.h"
#include "sessions/session_runner.h"

namespace hapticlab::planning::population_fit {

namespace {

using analysis::Measure;

// A bank study's options: one population at one rate, the forces' extremes kept.
SimulatedStudyOptions bank_study_options(const PopulationFitOptions& o, const PopulationParams& population,
                                         double rate_Hz) {
  SimulatedStudyOptions s;
  s.rate_Hz = rate_Hz;
  s.max_trial_s = o.max_trial_s;
  s.population = population;
  s.force_extremes = true;
  return s;
}

// The participants and thesis events of one simulated study.
void extract(const SimulatedStudy& s, const PopulationParams& design, std::uint64_t seed, const Names& names,
             StudyData& study, std::vector<ParticipantData>& participants) {
  for (const std::string& code : s.analysis.participants) {
    ParticipantData p;
    const ParticipantTraits t = ParticipantTraits::sample(sessions::participant_seed(seed, code), design);
    p.gain = t.visual_force_gain;
    p.consistency = t.consistency;
    std::vector<double> a, b, A, B, tH, tN, ltH, ltN;
    for (const analysis::TrialRecord& r : s.analysis.trials) {
      if (r.participant != code || r.task != "dissection" || r.status != "complete") continue;
      const auto x = s.force_extremes.find(r.trial_id);
      if (x == s.force_extremes.end()) continue;
      const double mean_N = x->second.mean_N[1], max_N = x->second.max_N[1];
      const double time_s = r.value(Measure::kCompletionTime, 0);
      if (!std::isfinite(mean_N) || !std::isfinite(max_N) || !(time_s > 0.0)) continue;
      if (r.setting == names.control) {
        a.push_back(mean_N);
        A.push_back(max_N);
        tH.push_back(time_s);
        ltH.push_back(std::log(time_s));
      } else if (r.setting == names.no_feedback) {
        b.push_back(mean_N);
        B.push_back(max_N);
        tN.push_back(time_s);
        ltN.push_back(std::log(time_s));
      }
    }
    p.valid = !a.empty() && !b.empty();
    p.a = mean_of(a), p.b = mean_of(b), p.A = mean_of(A), p.B = mean_of(B);
    p.tH = mean_of(tH), p.tN = mean_of(tN), p.log_tH = mean_of(ltH), p.log_tN = mean_of(ltN);
    study.participants.push_back(static_cast<int>(participants.size()));
    participants.push_back(p);
    study.mean_gain += p.gain / static_cast<double>(s.analysis.participants.size());
    study.mean_log_consistency += std::log(p.consistency) / static_cast<double>(s.analysis.participants.size());
  }
  bool nff_p95[2] = {false, false}, nff_median_clip = false, nff_time_sig[2] = {false, false}, other_p95 = false;
  int surgeons_tests = 0, surgeons_significant = 0;
  for (const Finding& f : findings_of(s.analysis)) {
    const int task = f.task == "dissection" ? 0 : 1;
    if (f.method == "pairwise") {
      if (f.setting == names.no_feedback) {
        if (f.measure == "force_p95_N") nff_p95[task] = f.significant;
        if (f.measure == "force_median_N" && task == 1) nff_median_clip = f.significant;
        if (f.measure == "completion_time_s") nff_time_sig[task] = f.significant;
      } else if (f.measure == "force_p95_N" && f.significant) {
        other_p95 = true;
      }
    } else if (f.method == "participant" && f.measure == "force_p95_N") {
      ++surgeons_tests;
      surgeons_significant += f.significant ? 1 : 0;
    }
  }
  study.outcome[kNffP95Dissection] = nff_p95[0];
  study.outcome[kNffP95Clip] = nff_p95[1];
  study.outcome[kNffMedianClip] = nff_median_clip;
  study.outcome[kNffTimeDissection] = !nff_time_sig[0];
  study.outcome[kNffTimeClip] = !nff_time_sig[1];
  study.outcome[kOthersP95] = !other_p95;
  // The thesis had five such tests (S1, S2 both tasks; S3 dissection).
  study.outcome[kSurgeonsP95] = surgeons_tests == 5 && surgeons_significant == 5;
}

double log_sum_exp(const std::vector<double>& v) {
  const double m = *std::max_element(v.begin(), v.end());
  if (!std::isfinite(m)) return m;
  double s = 0.0;
  for (double x : v) s += std::exp(x - m);
  return m + std::log(s);
}

void mixture_densities(Bank& bank) {
  const double log_d = std::log(static_cast<double>(bank.designs.size()));
  std::vector<double> terms(bank.designs.size());
  for (const ParticipantData& p : bank.participants) {
    for (std::size_t d = 0; d < bank.designs.size(); ++d)
      terms[d] = log_trait_density(bank.designs[d], p.gain, p.consistency);
    bank.log_q_participant.push_back(log_sum_exp(terms) - log_d);
  }
}

// Per-participant values of a few studies, matched by study seed and code.
std::map<std::pair<std::uint64_t, int>, ParticipantData> by_seed(const Bank& b) {
  std::map<std::pair<std::uint64_t, int>, ParticipantData> m;
  for (const StudyData& s : b.studies)
    for (std::size_t k = 0; k < s.participants.size(); ++k)
      m[{s.seed, static_cast<int>(k)}] = b.participants[static_cast<std::size_t>(s.participants[k])];
  return m;
}

}  // namespace

double mean_of(const std::vector<double>& v) {
  if (v.empty()) return kNaN;
  return std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

std::pair<double, double> mean_and_se(const std::vector<double>& v) {
  if (v.empty()) return {kNaN, kNaN};
  const double m = mean_of(v);
  double ss = 0.0;
  for (double x : v) ss += (x - m) * (x - m);
  const double se = v.size() > 1 ? std::sqrt(ss / static_cast<double>(v.size() - 1) / static_cast<double>(v.size())) : kNaN;
  return {m, se};
}

std::string fmt(double v, int digits) {
  char b[48];
  std::snprintf(b, sizeof b, "%.*g", digits, v);
  return b;
}

double log_trait_density(const PopulationParams& p, double gain, double consistency) {
  return log_density_visual_gain(gain, p) + log_density_consistency(consistency, p);
}

void parallel_for(int n, std::size_t jobs, const std::function<void(int)>& body,
                  const std::function<void(int)>& tick, const std::function<bool()>& stop) {
  if (jobs == 0) jobs = 2 * std::max(1u, std::thread::hardware_concurrency());
  jobs = std::min<std::size_t>(jobs, static_cast<std::size_t>(std::max(n, 1)));
  std::atomic<int> next{0}, done{0};
  std::atomic<bool> stopping{false};
  std::mutex m;
  std::exception_ptr error;
  std::vector<std::thread> pool;
  for (std::size_t t = 0; t < jobs; ++t)
    pool.emplace_back([&] {
      try {
        for (int k = next++; k < n && !stopping; k = next++) {
          body(k);
          ++done;
        }
      } catch (...) {
        const std::lock_guard<std::mutex> lock(m);
        if (!error) error = std::current_exception();
        stopping = true;
      }
    });
  while (done < n && !stopping) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    if (stop && stop()) stopping = true;
    if (tick) tick(done);
  }
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  if (tick) tick(done);
  if (done < n) throw std::runtime_error("interrupted; nothing written (run it again)");
}

Bank simulate_bank(const protocols::Protocol& protocol, int participants, const Names& names,
                   const PopulationFitOptions& o, std::vector<std::uint64_t>& seeds, const Progress& progress,
                   const Stop& stop) {
  Bank bank;
  bank.designs = design_populations();
  const int D = static_cast<int>(bank.designs.size());
  const int K = o.studies_per_design_point;
  std::vector<SimulatedStudy> simulated(static_cast<std::size_t>(D * K));
  seeds.assign(static_cast<std::size_t>(D * K), 0);
  for (int k = 0; k < D * K; ++k) seeds[static_cast<std::size_t>(k)] = study_seed(o.seed, participants, k);
  parallel_for(
      D * K, o.jobs,
      [&](int k) {
        const auto uk = static_cast<std::size_t>(k);
        simulated[uk] = simulate_study(protocol, participants, seeds[uk],
                                       bank_study_options(o, bank.designs[static_cast<std::size_t>(k / K)], o.rate_Hz));
      },
      [&](int done) { if (progress) progress("bank of simulated studies", done, D * K); }, stop);
  for (int k = 0; k < D * K; ++k) {
    StudyData s;
    s.design = k / K;
    s.seed = seeds[static_cast<std::size_t>(k)];
    const std::size_t first = bank.participants.size();
    extract(simulated[static_cast<std::size_t>(k)], bank.designs[static_cast<std::size_t>(s.design)], s.seed, names, s,
            bank.participants);
    for (std::size_t i = first; i < bank.participants.size(); ++i) bank.participants[i].study = k;
    bank.trials_run += simulated[static_cast<std::size_t>(k)].trials_run;
    bank.trials_timed_out += simulated[static_cast<std::size_t>(k)].trials_timed_out;
    bank.studies.push_back(std::move(s));
  }
  simulated.clear();
  mixture_densities(bank);
  return bank;
}

BankChecks check_bank(const protocols::Protocol& protocol, int participants, const Names& names,
                      const PopulationFitOptions& o, const Bank& bank, const std::vector<std::uint64_t>& seeds,
                      const Progress& progress, const Stop& stop) {
  const int D = static_cast<int>(bank.designs.size());
  const int K = o.studies_per_design_point;
  const int central = D / 2;
  const int checks = std::min(o.check_studies, K);
  Bank at_1kHz, novices;
  {
    PopulationParams novice = bank.designs[static_cast<std::size_t>(central)];
    novice.novice_share = 1.0;
    novice.novice_force_factor = 1.227;
    std::vector<SimulatedStudy> rate(static_cast<std::size_t>(checks)), nov(static_cast<std::size_t>(checks));
    parallel_for(
        2 * checks, o.jobs,
        [&](int k) {
          const int j = k % std::max(checks, 1);
          const std::uint64_t seed = seeds[static_cast<std::size_t>(central * K + j)];
          if (k < checks)
            rate[static_cast<std::size_t>(j)] = simulate_study(
                protocol, participants, seed, bank_study_options(o, bank.designs[static_cast<std::size_t>(central)], 1000.0));
          else
            nov[static_cast<std::size_t>(j)] = simulate_study(protocol, participants, seed, bank_study_options(o, novice, o.rate_Hz));
        },
        [&](int done) { if (progress) progress("rate and novice checks", done, 2 * checks); }, stop);
    for (int j = 0; j < checks; ++j) {
      const std::uint64_t seed = seeds[static_cast<std::size_t>(central * K + j)];
      StudyData s1, s2;
      s1.seed = s2.seed = seed;
      extract(rate[static_cast<std::size_t>(j)], bank.designs[static_cast<std::size_t>(central)], seed, names, s1, at_1kHz.participants);
      extract(nov[static_cast<std::size_t>(j)], novice, seed, names, s2, novices.participants);
      at_1kHz.studies.push_back(s1);
      novices.studies.push_back(s2);
    }
  }
  BankChecks c;
  const auto bank_by_seed = by_seed(bank);
  for (const auto& [key, p1k] : by_seed(at_1kHz)) {
    const auto it = bank_by_seed.find(key);
    if (it == bank_by_seed.end() || !p1k.valid || !it->second.valid) continue;
    const ParticipantData& p = it->second;
    c.d_mean.push_back(std::log(p1k.b / p1k.a) - std::log(p.b / p.a));
    c.d_peak.push_back(std::log(p1k.B / p1k.A) - std::log(p.B / p.A));
    c.d_time.push_back((p1k.log_tN - p1k.log_tH) - (p.log_tN - p.log_tH));
    c.d_level.push_back(std::log(p1k.a / p.a));
  }
  for (std::size_t j = 0; j < at_1kHz.studies.size(); ++j)
    for (const StudyData& s : bank.studies)
      if (s.seed == at_1kHz.studies[j].seed)
        for (int e = 0; e < kThesisEvents; ++e) {
          ++c.rate_events;
          c.rate_events_same += s.outcome[static_cast<std::size_t>(e)] == at_1kHz.studies[j].outcome[static_cast<std::size_t>(e)];
        }
  for (const auto& [key, pn] : by_seed(novices)) {
    const auto it = bank_by_seed.find(key);
    if (it == bank_by_seed.end() || !pn.valid || !it->second.valid) continue;
    c.d_novice.push_back(std::log(pn.a / it->second.a));
  }
  std::tie(c.novice_log_ratio, c.novice_se) = mean_and_se(c.d_novice);
  // Forces scale with the force level as level^kappa (1: proportionally).
  c.kappa = std::isfinite(c.novice_log_ratio) ? c.novice_log_ratio / std::log(1.227) : 1.0;
  return c;
}

}  // namespace hapticlab::planning::population_fit
