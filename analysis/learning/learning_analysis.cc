#include "analysis/learning/learning_analysis.h"

#include <cmath>
#include <iomanip>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::learning {
namespace {

// Text fields of our own (names from the table) may hold commas or quotes.
std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + "\"";
}

}  // namespace

LearningAnalysis analyze_learning(const TrialTable& table, Phase phase,
                                  const std::optional<CusumCriterion>& cusum) {
  if (cusum) validate(cusum->spec);
  LearningAnalysis out;
  out.measure = table.measure;
  out.phase = phase;
  for (const auto& p : table.participants) {
    auto it = p.phases.find(phase);
    if (it == p.phases.end()) continue;
    ParticipantLearning pl;
    pl.participant = p.participant;
    pl.group = p.group;
    pl.trial = it->second.trial;
    pl.value = it->second.value;
    pl.curve = fit_learning_curve(pl.trial, pl.value);
    if (cusum) {
      pl.cusum = cusum_chart(failures_against(pl.value, cusum->criterion, cusum->higher_is_better), cusum->spec);
    }
    out.participants.push_back(std::move(pl));
  }
  if (out.participants.empty()) {
    throw DataError(std::string("learning curves: no participant has trials in phase '") + phase_name(phase) +
                    "' (allowed: at least one participant with trials there)");
  }
  return out;
}

void write_curves_csv(const LearningAnalysis& analysis, std::ostream& out) {
  out << "participant,group,family,status,chosen,n,plateau,plateau_se,excess,excess_se,rate,rate_se,rate_kind,"
         "trials_to_90,beyond_data,residual_sd,aicc,akaike_weight,reason\n";
  out << std::setprecision(10);
  for (const auto& p : analysis.participants) {
    double best = INFINITY;
    for (const auto& f : p.curve.fits)
      if (f.ok()) best = std::min(best, f.aicc);
    double total = 0.0;
    for (const auto& f : p.curve.fits)
      if (f.ok()) total += std::exp(-(f.aicc - best) / 2.0);
    for (const auto& f : p.curve.fits) {
      out << csv_field(p.participant) << ',' << csv_field(p.group) << ',' << family_name(f.family) << ','
          << (f.ok() ? "ok" : refusal_name(f.refusal)) << ',' << (p.curve.chosen == f.family ? 1 : 0) << ','
          << p.trial.size() << ',';
      if (f.ok()) {
        const bool curve = f.family != CurveFamily::kConstant;
        out << f.a << ',' << f.se_a << ',';
        if (curve) {
          out << f.b << ',' << f.se_b << ',' << f.rate << ',' << f.se_rate << ','
              << (f.family == CurveFamily::kPower ? "c" : "tau_trials") << ',' << f.trials_to_90 << ','
              << (f.trials_to_90_beyond_data ? 1 : 0) << ',';
        } else {
          out << ",,,,,,,";
        }
        out << f.residual_sd << ',' << f.aicc << ',' << std::exp(-(f.aicc - best) / 2.0) / total << ",\n";
      } else {
        out << ",,,,,,,,,,,," << csv_field(f.reason) << '\n';
      }
    }
  }
}

void write_cusum_csv(const LearningAnalysis& analysis, std::ostream& out) {
  out << "participant,group,trial,value,failure,score,lc_score,h0,h1,s\n";
  out << std::setprecision(10);
  for (const auto& p : analysis.participants) {
    if (!p.cusum) continue;
    const CusumChart& c = *p.cusum;
    for (std::size_t i = 0; i < p.trial.size(); ++i) {
      const bool failed = (i == 0 ? c.score[0] : c.score[i] - c.score[i - 1]) > 0.0;
      out << csv_field(p.participant) << ',' << csv_field(p.group) << ',' << p.trial[i] << ',' << p.value[i] << ','
          << (failed ? 1 : 0) << ',' << c.score[i] << ',' << c.lc_score[i] << ',' << c.h0 << ',' << c.h1 << ','
          << c.s << '\n';
    }
  }
}

}  // namespace hapticlab::analysis::learning
