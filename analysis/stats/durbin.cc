#include "analysis/stats/durbin.h"

#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "analysis/stats/data_error.h"
#include "analysis/stats/distributions.h"
#include "analysis/stats/ranks.h"

namespace hapticlab::analysis {

namespace {

// Design checks: one observation per cell, equal block sizes k. Returns k.
std::size_t checked_block_size(const BlockTable& table) {
  const std::size_t t = table.treatment_count();
  const std::size_t b = table.block_count();
  std::size_t k = 0;
  for (std::size_t i = 0; i < b; ++i) {
    std::size_t size = 0;
    for (std::size_t j = 0; j < t; ++j) {
      const auto& cell = table.cells[i][j];
      if (cell.size() > 1) {
        throw DataError("Durbin test: block '" + table.block_names[i] + "', treatment '" +
                        table.treatment_names[j] + "' has " + std::to_string(cell.size()) +
                        " observations; the Durbin test takes one per cell");
      }
      if (cell.size() == 1 && !std::isfinite(cell[0])) {
        throw DataError("Durbin test: block '" + table.block_names[i] + "', treatment '" +
                        table.treatment_names[j] + "' holds a non-finite value");
      }
      size += cell.size();
    }
    if (i == 0) k = size;
    if (size != k) {
      throw DataError("Durbin test: block '" + table.block_names[i] + "' holds " +
                      std::to_string(size) + " treatments but block '" + table.block_names[0] +
                      "' holds " + std::to_string(k) +
                      "; a balanced incomplete block design has equal block sizes "
                      "(use the Skillings-Mack test otherwise)");
    }
  }
  if (k < 2) throw DataError("Durbin test: blocks must hold at least 2 treatments");
  return k;
}

// Replication r and pair balance λ: every treatment in r blocks, every pair
// together in λ blocks. Returns r.
std::size_t checked_replication(const BlockTable& table) {
  const std::size_t t = table.treatment_count();
  const std::size_t b = table.block_count();
  std::vector<std::size_t> replication(t, 0);
  std::vector<std::vector<std::size_t>> together(t, std::vector<std::size_t>(t, 0));
  for (std::size_t i = 0; i < b; ++i) {
    for (std::size_t j = 0; j < t; ++j) {
      if (table.cells[i][j].empty()) continue;
      ++replication[j];
      for (std::size_t l = j + 1; l < t; ++l) {
        if (!table.cells[i][l].empty()) ++together[j][l];
      }
    }
  }
  const std::size_t r = replication[0];
  for (std::size_t j = 0; j < t; ++j) {
    if (replication[j] != r) {
      throw DataError("Durbin test: treatment '" + table.treatment_names[j] + "' appears in " +
                      std::to_string(replication[j]) + " blocks but treatment '" +
                      table.treatment_names[0] + "' in " + std::to_string(r) +
                      "; a balanced incomplete block design replicates every treatment equally");
    }
  }
  const std::size_t lambda = t > 1 ? together[0][1] : 0;
  for (std::size_t j = 0; j < t; ++j) {
    for (std::size_t l = j + 1; l < t; ++l) {
      if (together[j][l] != lambda) {
        throw DataError("Durbin test: treatments '" + table.treatment_names[j] + "' and '" +
                        table.treatment_names[l] + "' share " + std::to_string(together[j][l]) +
                        " blocks but '" + table.treatment_names[0] + "' and '" +
                        table.treatment_names[1] + "' share " + std::to_string(lambda) +
                        "; the design is not balanced (use the Skillings-Mack test)");
      }
    }
  }
  return r;
}

struct BlockRanks {
  std::vector<double> rank_sums;  // R_j
  double a = 0.0;                 // A = Σ rank²
};

// Ranks within blocks; A = Σ rank², R_j.
BlockRanks rank_within_blocks(const BlockTable& table) {
  const std::size_t t = table.treatment_count();
  const std::size_t b = table.block_count();
  std::vector<double> rank_sums(t, 0.0);
  double a = 0.0;
  std::vector<double> values;
  std::vector<std::size_t> which;
  for (std::size_t i = 0; i < b; ++i) {
    values.clear();
    which.clear();
    for (std::size_t j = 0; j < t; ++j) {
      if (table.cells[i][j].empty()) continue;
      values.push_back(table.cells[i][j][0]);
      which.push_back(j);
    }
    const Ranking ranking = average_ranks(values);
    for (std::size_t m = 0; m < which.size(); ++m) {
      rank_sums[which[m]] += ranking.ranks[m];
      a += ranking.ranks[m] * ranking.ranks[m];
    }
  }
  return {std::move(rank_sums), a};
}

}  // namespace

DurbinResult durbin_test(const BlockTable& table) {
  const std::size_t t = table.treatment_count();
  const std::size_t b = table.block_count();
  if (t < 2) throw DataError("Durbin test: at least 2 treatments are needed");
  if (b < 2) throw DataError("Durbin test: at least 2 blocks are needed");
  const std::size_t k = checked_block_size(table);
  const std::size_t r = checked_replication(table);
  const auto [rank_sums, a] = rank_within_blocks(table);

  const double td = static_cast<double>(t);
  const double bd = static_cast<double>(b);
  const double kd = static_cast<double>(k);
  const double rd = static_cast<double>(r);
  const double c = bd * kd * (kd + 1.0) * (kd + 1.0) / 4.0;
  const double expected = rd * (kd + 1.0) / 2.0;
  double squares = 0.0;
  for (double s : rank_sums) squares += (s - expected) * (s - expected);

  DurbinResult result;
  TestResult& chi = result.chi_square;
  chi.method = "Durbin";
  chi.df = td - 1.0;
  chi.blocks = b;
  chi.treatments = t;
  chi.observations = b * k;
  // A − C is the within-block rank variance; 0 only if every block is tied.
  const bool degenerate = a - c <= 1e-12 * a;
  chi.statistic = degenerate ? 0.0 : (td - 1.0) * squares / (a - c);
  chi.p = chi_squared_upper(chi.statistic, chi.df);

  result.f_df1 = td - 1.0;
  result.f_df2 = bd * kd - bd - td + 1.0;
  const double denominator = (bd * (kd - 1.0) - chi.statistic) / result.f_df2;
  result.f = denominator > 0.0 ? (chi.statistic / (td - 1.0)) / denominator
                               : std::numeric_limits<double>::infinity();
  result.f_p = result.f_df2 > 0.0 ? f_upper(result.f, result.f_df1, result.f_df2)
                                  : std::numeric_limits<double>::quiet_NaN();
  return result;
}

}  // namespace hapticlab::analysis
