#include "core/sim/population.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace hapticlab {

namespace {

std::string text(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

void require(bool ok, const char* field, double value, const std::string& range) {
  if (!ok)
    throw std::invalid_argument(std::string("population: ") + field + " is " + text(value) + ", but must be " +
                                range);
}

// Inverse CDF of Normal(mean, sd) truncated to [lo, hi], at u in (0, 1).
double truncated_normal(double u, double mean, double sd, double lo, double hi) noexcept {
  if (!(sd > 0.0)) return std::clamp(mean, lo, hi);
  const double a = standard_normal_cdf((lo - mean) / sd);
  const double b = standard_normal_cdf((hi - mean) / sd);
  const double p = std::clamp(a + u * (b - a), 1e-300, 1.0 - 1e-16);
  return std::clamp(mean + sd * standard_normal_quantile(p), lo, hi);
}

double truncated_normal_log_density(double x, double mean, double sd, double lo, double hi) noexcept {
  if (!(x >= lo && x <= hi)) return -std::numeric_limits<double>::infinity();
  const double mass = standard_normal_cdf((hi - mean) / sd) - standard_normal_cdf((lo - mean) / sd);
  const double z = (x - mean) / sd;
  return -0.5 * z * z - std::log(sd * std::sqrt(2.0 * std::numbers::pi) * mass);
}

}  // namespace

double standard_normal_cdf(double x) noexcept { return 0.5 * std::erfc(-x / std::numbers::sqrt2); }

double standard_normal_quantile(double p) noexcept {
  if (!(p > 0.0)) return -std::numeric_limits<double>::infinity();
  if (!(p < 1.0)) return std::numeric_limits<double>::infinity();
  // Acklam's rational approximation (relative error < 1.2e-9), then one
  // Halley step on the exact CDF.
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
                                 1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
                                 6.680131188771972e+01,  -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                 -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
                                 3.754408661907416e+00};
  constexpr double low = 0.02425, high = 1.0 - low;
  double x;
  if (p < low) {
    const double q = std::sqrt(-2.0 * std::log(p));
    x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  } else if (p <= high) {
    const double q = p - 0.5, r = q * q;
    x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
  } else {
    const double q = std::sqrt(-2.0 * std::log(1.0 - p));
    x = -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) /
        ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  }
  const double e = standard_normal_cdf(x) - p;
  const double u = e * std::sqrt(2.0 * std::numbers::pi) * std::exp(0.5 * x * x);
  return x - u / (1.0 + 0.5 * x * u);
}

void PopulationParams::validate() const {
  require(visual_gain_mean >= kVisualGainRange.first && visual_gain_mean <= kVisualGainRange.second,
          "visual_gain_mean", visual_gain_mean, "within 0.2..1.0");
  require(visual_gain_sd > 0.0 && visual_gain_sd <= 0.5, "visual_gain_sd", visual_gain_sd, "in (0, 0.5]");
  require(consistency_median >= kConsistencyRange.first && consistency_median <= kConsistencyRange.second,
          "consistency_median", consistency_median, "within 0.02..0.6");
  require(consistency_log_sd > 0.0 && consistency_log_sd <= 1.0, "consistency_log_sd", consistency_log_sd,
          "in (0, 1]");
  require(force_level_log_sd >= 0.0 && force_level_log_sd <= 1.0, "force_level_log_sd", force_level_log_sd,
          "within 0..1");
  require(novice_force_factor >= 1.0 && novice_force_factor <= 2.0, "novice_force_factor", novice_force_factor,
          "within 1..2");
  require(novice_share >= 0.0 && novice_share <= 1.0, "novice_share", novice_share, "within 0..1");
  require(visual_noise_log_sd > 0.0 && visual_noise_log_sd <= 1.0, "visual_noise_log_sd", visual_noise_log_sd,
          "in (0, 1]");
}

std::string describe_participant_model(const PopulationParams& p) {
  std::string text = "participant model " + std::to_string(kParticipantModelVersion) + "; population";
  for (int i = 0; i < PopulationParams::kFields; ++i) {
    const auto [name, value] = p.field(i);
    char number[32];
    // The shortest text that reads back as the same double: exact, so
    // equal texts are equal models, and short enough to read.
    const auto end = std::to_chars(number, number + sizeof number, value).ptr;
    text += std::string(" ") + name + "=" + std::string(number, end);
  }
  return text;
}

std::pair<const char*, double> PopulationParams::field(int i) const noexcept {
  switch (i) {
    case 0: return {"visual_gain_mean", visual_gain_mean};
    case 1: return {"visual_gain_sd", visual_gain_sd};
    case 2: return {"consistency_median", consistency_median};
    case 3: return {"consistency_log_sd", consistency_log_sd};
    case 4: return {"force_level_log_sd", force_level_log_sd};
    case 5: return {"novice_force_factor", novice_force_factor};
    case 6: return {"novice_share", novice_share};
    default: return {"visual_noise_log_sd", visual_noise_log_sd};
  }
}

bool PopulationParams::set_field(const std::string& name, double value) noexcept {
  double* fields[kFields] = {&visual_gain_mean,   &visual_gain_sd,      &consistency_median, &consistency_log_sd,
                             &force_level_log_sd, &novice_force_factor, &novice_share,       &visual_noise_log_sd};
  for (int i = 0; i < kFields; ++i)
    if (name == field(i).first) {
      *fields[i] = value;
      return true;
    }
  return false;
}

double draw_visual_gain(double u, const PopulationParams& p) noexcept {
  return truncated_normal(u, p.visual_gain_mean, p.visual_gain_sd, kVisualGainRange.first, kVisualGainRange.second);
}

double draw_consistency(double u, const PopulationParams& p) noexcept {
  return std::exp(truncated_normal(u, std::log(p.consistency_median), p.consistency_log_sd,
                                   std::log(kConsistencyRange.first), std::log(kConsistencyRange.second)));
}

double draw_force_level(double u, bool novice, const PopulationParams& p) noexcept {
  const double median = novice ? p.novice_force_factor : 1.0;
  if (!(p.force_level_log_sd > 0.0)) return median;
  return std::exp(truncated_normal(u, std::log(median), p.force_level_log_sd, std::log(kForceLevelRange.first),
                                   std::log(kForceLevelRange.second)));
}

double log_density_visual_gain(double gain, const PopulationParams& p) noexcept {
  return truncated_normal_log_density(gain, p.visual_gain_mean, p.visual_gain_sd, kVisualGainRange.first,
                                      kVisualGainRange.second);
}

double log_density_consistency(double consistency, const PopulationParams& p) noexcept {
  if (!(consistency > 0.0)) return -std::numeric_limits<double>::infinity();
  // Density of c from that of log c: divide by c.
  return truncated_normal_log_density(std::log(consistency), std::log(p.consistency_median), p.consistency_log_sd,
                                      std::log(kConsistencyRange.first), std::log(kConsistencyRange.second)) -
         std::log(consistency);
}

}  // namespace hapticlab
