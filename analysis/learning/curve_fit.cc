#include "analysis/learning/curve_fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis::learning {
namespace {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<Vec3, 3>;

// Basis g(n; rate) multiplying b: n^(-c) or exp(-n / tau).
double basis(CurveFamily family, double n, double rate) {
  return family == CurveFamily::kPower ? std::pow(n, -rate) : std::exp(-n / rate);
}
// d g / d rate.
double basis_rate_derivative(CurveFamily family, double n, double rate) {
  return family == CurveFamily::kPower ? -std::log(n) * std::pow(n, -rate)
                                       : std::exp(-n / rate) * n / (rate * rate);
}

double sum_squares(CurveFamily family, const std::vector<double>& n, const std::vector<double>& y,
                   const Vec3& p) {
  double sse = 0.0;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const double r = y[i] - (p[0] + p[1] * basis(family, n[i], p[2]));
    sse += r * r;
  }
  return sse;
}

// Gaussian elimination with partial pivoting; false when singular.
bool solve3(Mat3 m, Vec3 rhs, Vec3& x) {
  for (int col = 0; col < 3; ++col) {
    int pivot = col;
    for (int r = col + 1; r < 3; ++r)
      if (std::abs(m[r][col]) > std::abs(m[pivot][col])) pivot = r;
    if (!(std::abs(m[pivot][col]) > 0.0)) return false;
    std::swap(m[col], m[pivot]);
    std::swap(rhs[col], rhs[pivot]);
    for (int r = col + 1; r < 3; ++r) {
      const double f = m[r][col] / m[col][col];
      for (int c = col; c < 3; ++c) m[r][c] -= f * m[col][c];
      rhs[r] -= f * rhs[col];
    }
  }
  for (int r = 2; r >= 0; --r) {
    double s = rhs[r];
    for (int c = r + 1; c < 3; ++c) s -= m[r][c] * x[c];
    x[r] = s / m[r][r];
  }
  return std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]);
}

// a and b by linear least squares for a fixed rate; returns the SSE.
double linear_part(CurveFamily family, const std::vector<double>& n, const std::vector<double>& y,
                   double rate, double& a, double& b) {
  double sg = 0, sgg = 0, sy = 0, sgy = 0;
  const double m = static_cast<double>(n.size());
  for (std::size_t i = 0; i < n.size(); ++i) {
    const double g = basis(family, n[i], rate);
    sg += g;
    sgg += g * g;
    sy += y[i];
    sgy += g * y[i];
  }
  const double det = m * sgg - sg * sg;
  if (!(std::abs(det) > 1e-300)) return std::numeric_limits<double>::infinity();
  b = (m * sgy - sg * sy) / det;
  a = (sy - b * sg) / m;
  return sum_squares(family, n, y, {a, b, rate});
}

double aicc(double sse, std::size_t n, std::size_t parameters) {
  const double k = static_cast<double>(parameters + 1);  // + the residual variance
  const double m = static_cast<double>(n);
  // An exact fit (noise-free data) has SSE 0: floor it so AICc stays finite
  // and still ranks an exact fit first.
  const double s = std::max(sse / m, 1e-300);
  return m * std::log(s) + 2.0 * k + 2.0 * k * (k + 1.0) / (m - k - 1.0);
}

CurveFit refused(CurveFamily family, FitRefusal why, std::string reason) {
  CurveFit fit;
  fit.family = family;
  fit.refusal = why;
  fit.reason = std::move(reason);
  return fit;
}

CurveFit fit_constant(const std::vector<double>& y) {
  CurveFit fit;
  fit.family = CurveFamily::kConstant;
  double mean = 0.0;
  for (double v : y) mean += v;
  mean /= static_cast<double>(y.size());
  double sse = 0.0;
  for (double v : y) sse += (v - mean) * (v - mean);
  fit.a = mean;
  fit.sse = sse;
  fit.residual_sd = std::sqrt(sse / static_cast<double>(y.size() - 1));
  fit.se_a = fit.residual_sd / std::sqrt(static_cast<double>(y.size()));
  fit.aicc = aicc(sse, y.size(), 1);
  return fit;
}

}  // namespace

const char* family_name(CurveFamily family) {
  switch (family) {
    case CurveFamily::kPower: return "power";
    case CurveFamily::kExponential: return "exponential";
    case CurveFamily::kConstant: return "constant";
  }
  return "?";
}

const char* refusal_name(FitRefusal refusal) {
  switch (refusal) {
    case FitRefusal::kNone: return "none";
    case FitRefusal::kTooFewTrials: return "too_few_trials";
    case FitRefusal::kNotConverged: return "not_converged";
    case FitRefusal::kNotIdentifiable: return "not_identifiable";
    case FitRefusal::kRateNotPositive: return "rate_not_positive";
  }
  return "?";
}

double CurveFit::predict(double n) const {
  if (family == CurveFamily::kConstant) return a;
  return a + b * basis(family, n, rate);
}

namespace {

// Refuses (DataError) points the fit cannot take.
void check_points(const std::vector<double>& n, const std::vector<double>& y) {
  if (n.size() != y.size()) {
    std::ostringstream m;
    m << "learning curve: " << n.size() << " trial indices but " << y.size() << " values";
    throw DataError(m.str());
  }
  for (std::size_t i = 0; i < n.size(); ++i) {
    if (!std::isfinite(n[i]) || n[i] < 1.0 || !std::isfinite(y[i])) {
      std::ostringstream m;
      m << "learning curve: point " << i + 1 << " has trial index " << n[i] << " and value " << y[i]
        << " (allowed: trial index >= 1 and a finite value)";
      throw DataError(m.str());
    }
  }
}

// Start: the rate on a log grid, a and b by linear least squares for each
// (the model is linear in them); the best grid point starts LM. This finds
// the basin without a user-supplied guess.
Vec3 grid_start(CurveFamily family, const std::vector<double>& n, const std::vector<double>& y) {
  const double n_max = *std::max_element(n.begin(), n.end());
  const double lo = family == CurveFamily::kPower ? 0.01 : 0.1;
  const double hi = family == CurveFamily::kPower ? 5.0 : 10.0 * n_max;
  constexpr int kGrid = 120;
  Vec3 p{0, 0, 0};
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k <= kGrid; ++k) {
    const double rate = lo * std::pow(hi / lo, static_cast<double>(k) / kGrid);
    double a = 0, b = 0;
    const double sse = linear_part(family, n, y, rate, a, b);
    if (sse < best) {
      best = sse;
      p = {a, b, rate};
    }
  }
  return p;
}

double total_sum_squares(const std::vector<double>& y) {
  double mean = 0.0;
  for (double v : y) mean += v;
  mean /= static_cast<double>(y.size());
  double ss_total = 0.0;
  for (double v : y) ss_total += (v - mean) * (v - mean);
  return ss_total;
}

// J'J and J'r of the model at q.
void normal_equations(CurveFamily family, const std::vector<double>& n, const std::vector<double>& y, const Vec3& q,
                      Mat3& a, Vec3& g) {
  a = {};
  g = {};
  for (std::size_t i = 0; i < n.size(); ++i) {
    const double bas = basis(family, n[i], q[2]);
    const Vec3 j{1.0, bas, q[1] * basis_rate_derivative(family, n[i], q[2])};
    const double r = y[i] - (q[0] + q[1] * bas);
    for (int u = 0; u < 3; ++u) {
      g[u] += j[u] * r;
      for (int v = 0; v < 3; ++v) a[u][v] += j[u] * j[v];
    }
  }
}

struct LmResult {
  Vec3 p{};
  double sse = 0.0;
  std::size_t iter = 0;
  bool converged = false;
};

// Levenberg-Marquardt with Marquardt's diagonal scaling, from p.
LmResult levenberg_marquardt(CurveFamily family, const std::vector<double>& n, const std::vector<double>& y, Vec3 p) {
  const double ss_total = total_sum_squares(y);
  double sse = sum_squares(family, n, y, p);
  double lambda = 1e-3;
  bool converged = false;
  std::size_t iter = 0;
  Mat3 jtj{};
  auto normal_equations = [&](const Vec3& q, Mat3& a, Vec3& g) { learning::normal_equations(family, n, y, q, a, g); };
  constexpr std::size_t kMaxIterations = 500;
  Vec3 grad{};
  for (iter = 0; iter < kMaxIterations && !converged; ++iter) {
    if (sse <= 1e-28 * std::max(ss_total, 1e-300)) {
      converged = true;  // an exact fit: nothing left to reduce
      break;
    }
    normal_equations(p, jtj, grad);
    bool accepted = false;
    while (!accepted) {
      Mat3 aug = jtj;
      for (int u = 0; u < 3; ++u) aug[u][u] += lambda * std::max(jtj[u][u], 1e-300);
      Vec3 step{};
      const bool solved = solve3(aug, grad, step);
      const Vec3 q{p[0] + step[0], p[1] + step[1], p[2] + step[2]};
      const double trial_sse =
          solved && q[2] > 0.0 ? sum_squares(family, n, y, q) : std::numeric_limits<double>::infinity();
      if (std::isfinite(trial_sse) && trial_sse <= sse) {
        const double reduction = sse - trial_sse;
        double step_norm = 0.0, p_norm = 0.0;
        for (int u = 0; u < 3; ++u) {
          step_norm += step[u] * step[u];
          p_norm += q[u] * q[u];
        }
        p = q;
        sse = trial_sse;
        lambda = std::max(lambda / 10.0, 1e-12);
        accepted = true;
        if (reduction <= 1e-14 * sse || std::sqrt(step_norm) <= 1e-10 * (std::sqrt(p_norm) + 1e-10))
          converged = true;
      } else {
        lambda *= 10.0;
        if (lambda > 1e14) {
          // No step reduces the SSE: converged only if the gradient, scaled
          // by each parameter's curvature, is zero to rounding.
          double worst = 0.0;
          for (int u = 0; u < 3; ++u)
            if (jtj[u][u] > 0.0) worst = std::max(worst, std::abs(grad[u]) / std::sqrt(jtj[u][u] * std::max(sse, 1e-300)));
          converged = worst < 1e-6;
          if (!converged) iter = kMaxIterations;
          break;
        }
      }
    }
    if (lambda > 1e14) break;
  }
  return {p, sse, iter, converged};
}

// The fit at the optimum p with its standard errors, or a refusal when the
// parameters are not identifiable.
CurveFit fit_with_errors(CurveFamily family, const std::vector<double>& n, const std::vector<double>& y,
                         const Vec3& p, double sse, std::size_t iter) {
  const std::size_t m = n.size();
  const double n_max = *std::max_element(n.begin(), n.end());
  Mat3 jtj{};
  // Covariance sigma^2 (J'J)^-1 at the optimum (as scipy's curve_fit with
  // absolute_sigma=False). Singular in the correlation scale: refuse.
  Vec3 unused{};
  normal_equations(family, n, y, p, jtj, unused);
  Mat3 corr{};
  for (int u = 0; u < 3; ++u) {
    if (!(jtj[u][u] > 0.0)) {
      return refused(family, FitRefusal::kNotIdentifiable,
                     std::string("not_identifiable: the ") + family_name(family) +
                         " fit's parameter " + "abr"[u] + " does not change the curve (no learning in the data?)");
    }
    for (int v = 0; v < 3; ++v) corr[u][v] = jtj[u][v] / std::sqrt(jtj[u][u] * jtj[v][v]);
  }
  Mat3 inv{};
  for (int col = 0; col < 3; ++col) {
    Vec3 e{0, 0, 0};
    e[col] = 1.0;
    Vec3 x{};
    if (!solve3(corr, e, x)) {
      return refused(family, FitRefusal::kNotIdentifiable,
                     std::string("not_identifiable: the ") + family_name(family) + " fit's J'J is singular");
    }
    for (int r = 0; r < 3; ++r) inv[r][col] = x[r];
  }
  // Condition: a huge diagonal of the inverse correlation (variance
  // inflation) means two parameters trade off exactly.
  for (int u = 0; u < 3; ++u) {
    if (!(inv[u][u] < 1e12)) {
      std::ostringstream msg;
      msg << "not_identifiable: the " << family_name(family) << " fit's parameters trade off (variance inflation "
          << inv[u][u] << ", allowed < 1e12)";
      return refused(family, FitRefusal::kNotIdentifiable, msg.str());
    }
  }
  CurveFit fit;
  fit.family = family;
  fit.a = p[0];
  fit.b = p[1];
  fit.rate = p[2];
  fit.sse = sse;
  fit.iterations = iter;
  const double dof = static_cast<double>(m - 3);
  fit.residual_sd = std::sqrt(sse / dof);
  const double s2 = sse / dof;
  fit.se_a = std::sqrt(s2 * inv[0][0] / jtj[0][0]);
  fit.se_b = std::sqrt(s2 * inv[1][1] / jtj[1][1]);
  fit.se_rate = std::sqrt(s2 * inv[2][2] / jtj[2][2]);
  fit.aicc = aicc(sse, m, 3);
  fit.trials_to_90 = family == CurveFamily::kPower ? std::pow(10.0, 1.0 / fit.rate)
                                                   : 1.0 + fit.rate * std::log(10.0);
  fit.trials_to_90_beyond_data = !(fit.trials_to_90 <= n_max);
  return fit;
}


}  // namespace

CurveFit fit_curve(CurveFamily family, const std::vector<double>& n, const std::vector<double>& y) {
  check_points(n, y);
  if (n.size() < kMinTrialsForFit) {
    std::ostringstream m;
    m << "too_few_trials: " << n.size() << " trials, a " << family_name(family)
      << " fit needs at least " << kMinTrialsForFit << " (3 parameters and the variance; AICc needs n > 5)";
    return refused(family, FitRefusal::kTooFewTrials, m.str());
  }
  if (family == CurveFamily::kConstant) return fit_constant(y);
  const LmResult lm = levenberg_marquardt(family, n, y, grid_start(family, n, y));
  const Vec3& p = lm.p;
  const double sse = lm.sse;
  const bool converged = lm.converged;
  const std::size_t iter = lm.iter;
  if (!converged) {
    std::ostringstream msg;
    msg << "not_converged: the " << family_name(family) << " fit did not converge in " << iter
        << " Levenberg-Marquardt iterations (last SSE " << sse << ", a = " << p[0] << ", b = " << p[1]
        << ", rate = " << p[2] << "; parameters still drifting usually mean the trials do not reach a plateau)";
    return refused(family, FitRefusal::kNotConverged, msg.str());
  }
  if (!(p[2] > 0.0) || !std::isfinite(p[0]) || !std::isfinite(p[1])) {
    std::ostringstream msg;
    msg << "rate_not_positive: the " << family_name(family) << " fit's rate is " << p[2]
        << " (allowed: > 0)";
    return refused(family, FitRefusal::kRateNotPositive, msg.str());
  }

  return fit_with_errors(family, n, y, p, sse, iter);
}

const CurveFit& LearningCurve::fit(CurveFamily family) const {
  for (const auto& f : fits)
    if (f.family == family) return f;
  throw DataError(std::string("learning curve: no ") + family_name(family) + " fit");
}

LearningCurve fit_learning_curve(const std::vector<double>& n, const std::vector<double>& y) {
  LearningCurve curve;
  for (auto family : {CurveFamily::kPower, CurveFamily::kExponential, CurveFamily::kConstant})
    curve.fits.push_back(fit_curve(family, n, y));
  const CurveFit& power = curve.fits[0];
  const CurveFit& expo = curve.fits[1];
  if (!power.ok() && !expo.ok()) return curve;
  double best = std::numeric_limits<double>::infinity();
  for (const auto& f : curve.fits) {
    if (f.ok() && f.aicc < best) {
      best = f.aicc;
      curve.chosen = f.family;
    }
  }
  double total = 0.0;
  for (const auto& f : curve.fits)
    if (f.ok()) total += std::exp(-(f.aicc - best) / 2.0);
  curve.akaike_weight_chosen = 1.0 / total;
  return curve;
}

}  // namespace hapticlab::analysis::learning
