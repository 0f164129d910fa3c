#include "analysis/stats/skillings_mack.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "analysis/stats/data_error.h"
#include "analysis/stats/distributions.h"
#include "analysis/stats/ranks.h"

namespace hapticlab::analysis {

TestResult skillings_mack_test(const BlockTable& table) {
  const std::size_t t = table.treatment_count();
  if (t < 2) throw DataError("Skillings-Mack test: at least 2 treatments are needed");

  Eigen::VectorXd adjusted = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(t));
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(t),
                                                     static_cast<Eigen::Index>(t));
  TestResult result;
  result.method = "Skillings-Mack";
  result.treatments = t;

  std::vector<double> values;
  std::vector<Eigen::Index> which;
  for (std::size_t i = 0; i < table.block_count(); ++i) {
    values.clear();
    which.clear();
    for (std::size_t j = 0; j < t; ++j) {
      const auto& cell = table.cells[i][j];
      if (cell.size() > 1) {
        throw DataError("Skillings-Mack test: block '" + table.block_names[i] +
                        "', treatment '" + table.treatment_names[j] + "' has " +
                        std::to_string(cell.size()) +
                        " observations; the Skillings-Mack test takes at most one per cell");
      }
      if (cell.empty()) continue;
      if (!std::isfinite(cell[0])) {
        throw DataError("Skillings-Mack test: block '" + table.block_names[i] +
                        "', treatment '" + table.treatment_names[j] + "' holds a non-finite value");
      }
      values.push_back(cell[0]);
      which.push_back(static_cast<Eigen::Index>(j));
    }
    if (values.size() < 2) continue;  // a lone observation has no rank information
    const double k_i = static_cast<double>(values.size());
    const Ranking ranking = average_ranks(values);
    const double weight = std::sqrt(12.0 / (k_i + 1.0));
    for (std::size_t m = 0; m < which.size(); ++m) {
      adjusted(which[m]) += weight * (ranking.ranks[m] - (k_i + 1.0) / 2.0);
      covariance(which[m], which[m]) += k_i - 1.0;
      for (std::size_t l = m + 1; l < which.size(); ++l) {
        covariance(which[m], which[l]) -= 1.0;
        covariance(which[l], which[m]) -= 1.0;
      }
    }
    ++result.blocks;
    result.observations += values.size();
  }

  const Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(covariance);
  if (cod.rank() < static_cast<Eigen::Index>(t - 1)) {
    throw DataError("Skillings-Mack test: the treatments are not connected through blocks "
                    "with at least two observations (covariance rank " +
                    std::to_string(cod.rank()) + ", need " + std::to_string(t - 1) +
                    "); every treatment must share blocks, directly or through others");
  }
  const Eigen::MatrixXd inverse = cod.pseudoInverse();
  result.statistic = std::max(0.0, adjusted.dot(inverse * adjusted));
  result.df = static_cast<double>(t - 1);
  result.p = chi_squared_upper(result.statistic, result.df);
  return result;
}

}  // namespace hapticlab::analysis
