#include "planning/transfer_power.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "analysis/stats/wilson.h"
#include "core/common/random.h"

namespace hapticlab::planning {
namespace {

double median_change(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Each participant's change from the pre-test in `group` (without one, the
// test's time), for the post (retention = false) or retention test;
// participants without a complete trial in either test are left out, as
// analyze leaves out aborted trials.
std::vector<double> changes(const TransferStudy& s, int group, bool retention, bool pre_test) {
  std::vector<double> out;
  for (const TransferParticipant& p : s.participants) {
    if (p.group != group) continue;
    const double later = retention ? p.retention_s : p.post_s;
    const double before = pre_test ? p.pre_s : 0.0;
    if (std::isfinite(later) && std::isfinite(before)) out.push_back(later - before);
  }
  return out;
}

struct Outcome {
  bool computed = false;
  bool significant = false;
  double effect_s = 0.0;
};

}  // namespace

std::uint64_t transfer_study_seed(std::uint64_t seed, int per_group, int index) noexcept {
  return Random::derive(Random::derive(seed, 0x7472616e73666572ull).next_u64() ^ static_cast<std::uint64_t>(per_group),
                        static_cast<std::uint64_t>(index))
      .next_u64();
}

namespace {

void check_power_options(const TransferPowerOptions& options) {
  if (options.per_group.empty()) throw std::invalid_argument("participants per group: none given; give 1..999");
  for (int n : options.per_group) {
    if (n < 1 || n > 999)
      throw std::invalid_argument("participants per group is " + std::to_string(n) + ", but must be within 1..999");
  }
  if (options.studies < 1)
    throw std::invalid_argument("studies is " + std::to_string(options.studies) + ", but must be >= 1");
  if (!(options.alpha > 0.0 && options.alpha < 1.0))
    throw std::invalid_argument("alpha is " + std::to_string(options.alpha) + ", but must be in (0, 1)");
  if (options.jobs < 1) throw std::invalid_argument("jobs is " + std::to_string(options.jobs) + ", but must be >= 1");
}

// One power row from the studies' outcomes of one test and group.
TransferPowerRow row_of(const std::vector<Outcome>& outcomes, std::size_t stride, std::size_t offset) {
  TransferPowerRow row;
  std::vector<double> effects;
  for (std::size_t k = 0; k * stride < outcomes.size(); ++k) {
    const Outcome& o = outcomes[k * stride + offset];
    if (!o.computed) continue;
    ++row.studies;
    if (o.significant) ++row.significant;
    if (std::isfinite(o.effect_s)) effects.push_back(o.effect_s);
  }
  if (row.studies > 0) {
    row.power = static_cast<double>(row.significant) / row.studies;
    const analysis::ProportionInterval ci =
        analysis::wilson_interval(static_cast<std::size_t>(row.significant), static_cast<std::size_t>(row.studies));
    row.power_low = ci.low;
    row.power_high = ci.high;
  } else {
    row.power = row.power_low = row.power_high = std::numeric_limits<double>::quiet_NaN();
  }
  row.median_effect_s = median_change(effects);
  return row;
}

}  // namespace

TransferPower transfer_power(const TransferDesign& design, const TransferPowerOptions& options,
                             const GroupTest& test) {
  design.validate();
  check_power_options(options);
  const int groups = static_cast<int>(design.groups.size());
  const int tests = design.retention_trials > 0 ? 2 : 1;
  const bool pre_test = design.pre_trials > 0;
  // outcomes[study * per_study + test * (groups - 1) + group - 1]
  const std::size_t per_study = static_cast<std::size_t>(tests * (groups - 1));
  TransferPower out;
  for (int n : options.per_group) {
    std::vector<Outcome> outcomes(static_cast<std::size_t>(options.studies) * per_study);
    std::atomic<int> next{0};
    std::mutex mutex;
    std::exception_ptr failure;
    auto worker = [&] {
      for (int k = next++; k < options.studies; k = next++) {
        try {
          const TransferStudy s =
              simulate_transfer_study(design, n, transfer_study_seed(options.seed, n, k), options.simulation);
          std::vector<Outcome> mine(per_study);
          for (int t = 0; t < tests; ++t) {
            const std::vector<double> reference = changes(s, 0, t == 1, pre_test);
            for (int g = 1; g < groups; ++g) {
              const std::vector<double> values = changes(s, g, t == 1, pre_test);
              const double p = test(values, reference);
              Outcome& o = mine[static_cast<std::size_t>(t * (groups - 1) + g - 1)];
              o.computed = std::isfinite(p);
              o.significant = o.computed && p < options.alpha;
              o.effect_s = median_change(values) - median_change(reference);
            }
          }
          const std::lock_guard<std::mutex> lock(mutex);
          std::copy(mine.begin(), mine.end(), outcomes.begin() + static_cast<std::ptrdiff_t>(k * per_study));
          out.trials_run += s.trials_run;
          out.trials_timed_out += s.trials_timed_out;
          out.updates += s.updates;
        } catch (...) {
          const std::lock_guard<std::mutex> lock(mutex);
          if (!failure) failure = std::current_exception();
          next = options.studies;
        }
      }
    };
    std::vector<std::thread> threads;
    for (int j = 1; j < std::min(options.jobs, options.studies); ++j) threads.emplace_back(worker);
    worker();
    for (std::thread& t : threads) t.join();
    if (failure) std::rethrow_exception(failure);

    for (int t = 0; t < tests; ++t) {
      for (int g = 1; g < groups; ++g) {
        TransferPowerRow row = row_of(outcomes, per_study, static_cast<std::size_t>(t * (groups - 1) + g - 1));
        row.per_group = n;
        row.test = t == 0 ? "post" : "retention";
        row.group = design.groups[static_cast<std::size_t>(g)].name;
        row.reference = design.groups[0].name;
        out.rows.push_back(row);
      }
    }
  }
  return out;
}

}  // namespace hapticlab::planning
