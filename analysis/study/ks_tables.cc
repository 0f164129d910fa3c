#include "analysis/study/ks_tables.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>
#include <vector>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

struct Comparison {
  KsRow row;
  KsBootstrapOptions options;
};

struct Repetitions {
  std::vector<ParticipantRepetitions> data;
  std::size_t too_short = 0;
};

// Copies one comparison's series (gathered by the thread that runs it, so
// only the comparisons in progress hold copies).
Repetitions gather(const StudyAnalysis& a, const KsRow& row) {
  const AnalysisOptions& o = a.options;
  Repetitions c;
  const std::string& task = row.task;
  const int hand = row.hand;
  const std::string& setting = row.setting;
  const bool force = row.quantity == "force";
  for (const auto& participant : a.participants) {
    ParticipantRepetitions reps;
    reps.participant = participant;
    for (const TrialRecord& t : a.trials) {
      if (t.participant != participant || t.task != task) continue;
      const bool control = t.setting == a.control;
      if (!control && t.setting != setting) continue;
      const auto& series = force ? t.force_series_N[static_cast<std::size_t>(hand)]
                                 : t.speed_series_m_per_s[static_cast<std::size_t>(hand)];
      if (series.size() < o.ks_block_length) {
        if (!series.empty() || t.window) ++c.too_short;
        continue;
      }
      (control ? reps.control : reps.other).push_back(series);
    }
    if (!reps.control.empty() || !reps.other.empty()) c.data.push_back(std::move(reps));
  }
  return c;
}

void run(const StudyAnalysis& a, Comparison& c) {
  const Repetitions reps = gather(a, c.row);
  try {
    KsBootstrapResult r = ks_block_bootstrap(reps.data, c.options);
    r.d_intra.clear();
    r.d_intra.shrink_to_fit();
    r.d_inter.clear();
    r.d_inter.shrink_to_fit();
    c.row.result = std::move(r);
  } catch (const DataError& e) {
    c.row.note = e.what();
  }
  if (reps.too_short > 0) {
    c.row.note += (c.row.note.empty() ? "" : "; ") + std::to_string(reps.too_short) +
                  " repetition(s) shorter than the block length left out";
  }
}

}  // namespace

void add_ks_rows(StudyAnalysis& a, std::size_t threads) {
  const AnalysisOptions& o = a.options;
  std::vector<Comparison> comparisons;
  std::uint64_t comparison = 0;
  for (const auto& task : a.tasks) {
    for (int hand = 0; hand < 2; ++hand) {
      for (const char* quantity : {"force", "speed"}) {
        for (std::size_t si = 1; si < a.settings.size(); ++si) {
          ++comparison;
          Comparison& c = comparisons.emplace_back();
          c.row = KsRow{task, hand, quantity, a.settings[si], std::nullopt, {}};
          c.options.resamples = o.ks_resamples;
          c.options.block_length = o.ks_block_length;
          // Each comparison its own reproducible stream.
          c.options.seed = o.seed * 0x9E3779B97F4A7C15ULL + comparison;
          c.options.percentile_method = o.percentile_method;
        }
      }
    }
  }
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  threads = std::min(threads, comparisons.size());
  // Comparisons are taken in turn from a shared counter; each writes only its
  // own row, so the table is the same whichever thread ran what.
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  std::atomic<bool> failed{false};
  auto work = [&] {
    try {
      for (std::size_t i = next++; i < comparisons.size() && !failed; i = next++) run(a, comparisons[i]);
    } catch (...) {
      if (!failed.exchange(true)) failure = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
  for (Comparison& c : comparisons) a.ks.push_back(std::move(c.row));
}

}  // namespace hapticlab::analysis
