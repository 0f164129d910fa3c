#pragma once
// Learning curves of one participant and one measure over the trial index
// n = 1, 2, ... (issue 38 §2; docs/analysis.md "Learning curves and transfer
// designs"). Two 3-parameter families, both with their plateau a fitted:
//
//   power law of practice      y = a + b * n^(-c)        rate c > 0
//   exponential with plateau   y = a + b * exp(-n / tau) rate 1/tau, tau > 0
//
// fitted by nonlinear least squares (Levenberg-Marquardt, our own code),
// and a constant y = a (no learning). The family is chosen by AICc, which
// corrects AIC for small n (a participant has 10-40 trials; AIC then
// prefers too many parameters). Values are in the measure's own unit.
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace hapticlab::analysis::learning {

enum class CurveFamily { kPower, kExponential, kConstant };
const char* family_name(CurveFamily family);  // "power", "exponential", "constant"

// Why a family's fit is not reported (never a number that is garbage).
enum class FitRefusal {
  kNone,
  kTooFewTrials,     // n < kMinTrialsForFit
  kNotConverged,     // Levenberg-Marquardt did not meet its tolerance
  kNotIdentifiable,  // J'J singular at the optimum: a parameter is not determined
  kRateNotPositive,  // c <= 0 or tau <= 0: not a learning curve
};
const char* refusal_name(FitRefusal refusal);

// 3 parameters plus the residual variance: AICc needs n > K + 1 = 5.
inline constexpr std::size_t kMinTrialsForFit = 6;

struct CurveFit {
  CurveFamily family = CurveFamily::kConstant;
  FitRefusal refusal = FitRefusal::kNone;
  std::string reason;        // human-readable when refused
  double a = 0.0;            // plateau (measure unit)
  double b = 0.0;            // excess over the plateau at n^0 / exp(0) (measure unit)
  double rate = 0.0;         // c (power) or tau in trials (exponential); 0 for constant
  double se_a = 0.0, se_b = 0.0, se_rate = 0.0;  // standard errors, sigma^2 (J'J)^-1
  double sse = 0.0;          // residual sum of squares
  double residual_sd = 0.0;  // sqrt(sse / (n - parameters))
  double aicc = 0.0;
  std::size_t iterations = 0;
  // Trials to 90 % of the achievable improvement: the first trial n at which
  // the fitted excess over the plateau, y(n) - a, is at most 10 % of its
  // value at trial 1 (power: 10^(1/c); exponential: 1 + tau ln 10), as a
  // real number; `trials_to_90_beyond_data` when it exceeds the last trial.
  double trials_to_90 = 0.0;
  bool trials_to_90_beyond_data = false;
  bool ok() const { return refusal == FitRefusal::kNone; }
  // Fitted value at trial n (power, exponential or constant).
  double predict(double n) const;
};

// One family on values y[i] at trial indices n[i] (>= 1, any order). Throws
// DataError for sizes that differ, a trial index < 1, or a non-finite value
// (naming the index and value); returns a refused CurveFit otherwise.
CurveFit fit_curve(CurveFamily family, const std::vector<double>& trial,
                   const std::vector<double>& y);

struct LearningCurve {
  std::vector<CurveFit> fits;  // power, exponential, constant, in that order
  // The fitted family with the smallest AICc; nullopt when power and
  // exponential are both refused (the constant alone says nothing).
  std::optional<CurveFamily> chosen;
  double akaike_weight_chosen = 0.0;  // exp(-dAICc/2) normalised over the fits not refused
  const CurveFit& fit(CurveFamily family) const;
};

LearningCurve fit_learning_curve(const std::vector<double>& trial, const std::vector<double>& y);

}  // namespace hapticlab::analysis::learning
