#include "analysis/study/trial_reader.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>

#include "analysis/stats/data_error.h"
#include "db/chunk_reader.h"

namespace hapticlab::analysis {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::vector<double> every_kth(const std::vector<double>& values, std::size_t k) {
  std::vector<double> out;
  out.reserve(values.size() / k + 1);
  for (std::size_t i = 0; i < values.size(); i += k) out.push_back(values[i]);
  return out;
}

void mark_missing(TrialRecord& record) {
  for (auto& h : record.hands) {
    h.force_median_N = h.force_p95_N = h.speed_median_m_per_s = h.path_length_m = std::numeric_limits<double>::quiet_NaN();
  }
  for (auto* v : {&record.force_series_N, &record.speed_series_m_per_s, &record.force_quantiles_N,
                  &record.speed_quantiles_m_per_s}) {
    for (auto& x : *v) x.clear();
  }
}

// The channels the metrics read (add(), and add_device(): the first three
// raw joints only): the rest of each chunk is verified but never decoded
// (the others read NaN). 16 of the 28 channels; on the demo study this
// saves about a third of the bit-plane work.
constexpr db::ChannelSet kMetricChannels =
    db::channel_range(db::kChannelT, 1) | db::channel_range(db::kChannelRawFirst, 3) |
    db::channel_range(db::kChannelTipFirst, 3) | db::channel_range(db::kChannelTipVelocityFirst, 3) |
    db::channel_range(db::kChannelVeForceFirst, 3) | db::channel_range(db::kChannelJointForceFirst, 3);

// Updates the writer could not store (a full queue), logged where the gap
// begins: the samples on either side are consecutive to every measure.
struct SampleGap {
  double t_s = 0.0;
  std::int64_t updates = 0;
};

// A path length and an energy sum over consecutive samples, so across a
// gap they take one straight step for the whole of it (a 1 s gap shortened
// a path by 1.8 %): left out, and said. The energy covers the whole trial,
// the path length the task window. Medians, percentiles and the completion
// time stand on the samples there are.
void leave_out_across_gaps(TrialRecord& rec, const std::vector<SampleGap>& gaps) {
  if (gaps.empty()) return;
  std::int64_t updates = 0;
  bool in_window = false;
  for (const SampleGap& g : gaps) {
    updates += g.updates;
    in_window = in_window || (rec.window && g.t_s >= rec.window->start_s && g.t_s <= rec.window->end_s);
  }
  const bool had_energy = rec.energy[0] || rec.energy[1];
  if (!in_window && !had_energy) return;  // nothing it measures crosses a gap
  for (auto& e : rec.energy) e.reset();
  if (in_window)
    for (HandMetrics& h : rec.hands) h.path_length_m = std::numeric_limits<double>::quiet_NaN();
  char first[32];
  std::snprintf(first, sizeof first, "%.6g s", gaps.front().t_s);
  rec.note = std::to_string(updates) + " update(s) missing from the samples (" + std::to_string(gaps.size()) +
             " gap(s), the first at " + first + "): " +
             (in_window ? std::string("path length") + (had_energy ? " and energy" : "") : std::string("energy")) +
             " left out, as they would bridge a gap with one straight step";
}

// Per thread, reused from trial to trial (a trial-hand is ~10^5 samples).
struct Buffers {
  TrialAccumulator trial;
};

TrialRecord read_one(db::StudyDb& db, const db::TrialRow& row, const AnalysisOptions& options, Buffers& buf) {
  TrialRecord rec;
  rec.trial_id = row.id;
  rec.participant = row.participant_code;
  rec.task = row.task;
  rec.setting = row.setting_name;
  rec.repetition = row.repetition;
  rec.block = row.block;
  rec.position = row.position;
  rec.status = db::to_string(row.status);

  std::vector<TaskEvent> events;
  std::vector<SampleGap> gaps;
  for (const db::EventRow& e : db.events(row.id)) {
    if (const auto type = task_event_type(e.type)) {
      events.push_back({e.t_s, *type, static_cast<std::int8_t>(e.instrument), static_cast<std::int32_t>(e.item_index)});
    } else if (e.type == "samples_missing") {
      gaps.push_back({e.t_s, e.item_index});
    }
  }
  buf.trial.start(events, options);
  // A window of samples at a time, each hand's in tick order; misplaced
  // and damaged chunks are left out and named.
  db::TrialChunks chunks(db.connection(), row.id, -1, kMetricChannels);
  // As columns, in place in the chunk: the same values as StoredSample's
  // fields (the two raw joints outside the set read NaN there too).
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t hand = 0; hand < 2; ++hand) {
    const int instrument = static_cast<int>(hand);
    for (db::ColumnWindow w = chunks.next_columns(instrument); !w.empty(); w = chunks.next_columns(instrument)) {
      const auto three = [&](std::size_t first, std::size_t i) {
        return Vec3d{w.channel[first][i], w.channel[first + 1][i], w.channel[first + 2][i]};
      };
      for (std::size_t i = 0; i < w.size; ++i) {
        const Vec3d force_N = three(db::kChannelVeForceFirst, i);
        buf.trial.add(hand, w.t_s[i], three(db::kChannelTipFirst, i), three(db::kChannelTipVelocityFirst, i), force_N);
        const Vec3d raw = three(db::kChannelRawFirst, i);
        buf.trial.add_device(hand, {raw[0], raw[1], raw[2], kNaN, kNaN}, three(db::kChannelJointForceFirst, i), force_N);
      }
    }
  }
  std::vector<std::string> damaged;
  for (const db::BadChunk& c : chunks.bad()) {
    // Damage is left out and counted; a chunk of a format this HapticLab
    // does not know is not damage but data it cannot read, and analysing
    // the study without it would quietly answer another question.
    if (c.kind == db::ChunkError::Kind::kUnknownFormat)
      throw std::runtime_error("cannot analyse this study: " + db::describe(c) + "; analyse it with that HapticLab");
    damaged.push_back(db::describe(c));
  }
  buf.trial.finish(rec, std::move(damaged));
  leave_out_across_gaps(rec, gaps);
  return rec;
}

// How far past its samples a task event may lie. A VE logs an event in
// the update whose sample shows it, so an event's time is a sample's; the
// slack covers samples dropped at either end of a trial (a full queue for
// a moment), not an event of another clock (a wall-clock time beside loop
// times, an offset origin), which lies seconds to hours away.
constexpr double kEventSampleSlack_s = 0.5;

// "" when the task window lies within the trial's samples (give or take
// the slack); else why its measures are missing. A window reaching past
// the samples took its completion time from events the samples do not
// show (3600 s for a 2 s trial).
std::string window_outside_samples(const TaskWindow& w, double first_sample_s, double last_sample_s) {
  const auto text = [](double s) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g s", s);
    return std::string(buf);
  };
  std::string edge;
  if (w.start_s < first_sample_s - kEventSampleSlack_s)
    edge = "starts at " + text(w.start_s) + " (its first 20 mm insertion), before the first sample at " +
           text(first_sample_s);
  else if (w.end_s > last_sample_s + kEventSampleSlack_s)
    edge = "ends at " + text(w.end_s) + " (its last contact), after the last sample at " + text(last_sample_s);
  if (edge.empty()) return "";
  return "the task window " + edge + ": its events and samples disagree (two clocks, or an edited file); measures "
         "and completion time missing";
}

}  // namespace

std::optional<TaskEventType> task_event_type(std::string_view name) {
  for (int i = 0; i < kNumTaskEventTypes; ++i) {
    const auto type = static_cast<TaskEventType>(i);
    if (name == to_string(type)) return type;
  }
  return std::nullopt;  // the runner's and writer's own events do not bound the task
}

void TrialAccumulator::start(std::span<const TaskEvent> events, const AnalysisOptions& options) {
  options_ = &options;
  events_.assign(events.begin(), events.end());
  // The window before the samples are read: a contact still open when the
  // log stops ends at the trial's last sample, which is at or after every
  // sample, so an open end (+inf) selects the same samples; the end itself
  // is settled in finish(), once the last sample is known.
  provisional_ = task_window(events_, kInf);
  samples_ = 0;
  trial_end_s_ = -kInf;
  trial_start_s_ = kInf;
  data_error_.clear();
  accumulate_ = provisional_.window.has_value();
  for (EnergyAccumulator& e : energy_) e.start();
  have_energy_ = false;
  for (std::size_t hand = 0; hand < 2; ++hand) {
    if (accumulate_) acc_[hand].start(*provisional_.window, options.min_force_N, values_[hand]);
  }
}

void TrialAccumulator::fail(const std::string& why) {
  // The first problem is the one reported; the rest of the trial is still
  // counted (a damaged chunk found later takes precedence in finish()).
  if (data_error_.empty()) data_error_ = why;
  accumulate_ = false;
}

void TrialAccumulator::finish(TrialRecord& rec, std::vector<std::string> damaged_chunks) {
  const AnalysisOptions& options = *options_;
  mark_missing(rec);
  rec.window.reset();
  for (auto& e : rec.energy) e.reset();
  rec.damaged_chunks = std::move(damaged_chunks);
  if (!rec.damaged_chunks.empty()) {
    rec.problem =
        std::to_string(rec.damaged_chunks.size()) + " damaged sample chunk(s) left out (hapticlab study check)";
    return;
  }
  if (samples_ == 0) {
    rec.problem = "no samples logged";
    return;
  }
  // Over the whole trial, with or without a task window: an unstable
  // setting shows in it however the task went.
  if (have_energy_) {
    for (std::size_t hand = 0; hand < 2; ++hand) rec.energy[hand] = energy_[hand].result();
  }
  const bool open_end = provisional_.window && std::isinf(provisional_.window->end_s);
  const TaskWindowResult window = open_end ? task_window(events_, trial_end_s_) : provisional_;
  if (!window.window) {
    rec.problem = window.problem;
    return;
  }
  if (std::string outside = window_outside_samples(*window.window, trial_start_s_, trial_end_s_); !outside.empty()) {
    rec.problem = std::move(outside);
    return;
  }
  if (!data_error_.empty()) {
    rec.problem = data_error_;
    return;
  }
  try {
    for (std::size_t hand = 0; hand < 2; ++hand) {
      WindowValues& values = values_[hand];
      // The KS bootstrap needs the series in time order: decimate before sorting.
      rec.force_series_N[hand] = every_kth(values.force_N, options.ks_stride);
      rec.speed_series_m_per_s[hand] = every_kth(values.speed_m_per_s, options.ks_stride);
      HandQuantiles quantiles;
      rec.hands[hand] = summarize_window(values, options.percentile_method, options.cdf_points, &quantiles);
      rec.force_quantiles_N[hand] = std::move(quantiles.force_N);
      rec.speed_quantiles_m_per_s[hand] = std::move(quantiles.speed_m_per_s);
    }
    rec.window = window.window;
  } catch (const DataError& e) {
    // One damaged trial (a non-finite force, say) must not stop the study's analysis.
    rec.problem = e.what();
    mark_missing(rec);
  }
}

TrialRecord read_trial(db::StudyDb& db, const db::TrialRow& row, const AnalysisOptions& options) {
  Buffers buf;
  return read_one(db, row, options, buf);
}

std::vector<TrialRecord> read_trials(db::StudyDb& db, const std::vector<db::TrialRow>& rows,
                                     const AnalysisOptions& options, std::size_t threads) {
  std::vector<TrialRecord> out(rows.size());
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  threads = std::min(threads, rows.size());
  // An in-memory or temporary database cannot be opened a second time.
  const std::string& path = db.path();
  if (path.empty() || path == ":memory:" || path.starts_with("file::memory:")) threads = std::min<std::size_t>(threads, 1);

  std::atomic<std::size_t> next{0};
  std::mutex error_mutex;
  std::exception_ptr error;
  auto work = [&](db::StudyDb& conn) {
    Buffers buf;
    for (std::size_t i = next++; i < rows.size(); i = next++) {
      out[i] = read_one(conn, rows[i], options, buf);
    }
  };
  auto guarded = [&](auto&& body) {
    try {
      body();
    } catch (...) {
      const std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      next = rows.size();  // the others stop after their current trial
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) {
    pool.emplace_back([&] {
      guarded([&] {
        db::OpenOptions open;
        open.recover = false;
        open.read_only = true;
        open.integrity = db::OpenOptions::Integrity::kSkip;
        open.mmap_bytes = db::kBulkReadMmapBytes;
        db::StudyDb conn(path, open);
        work(conn);
      });
    });
  }
  guarded([&] { work(db); });
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  return out;
}

}  // namespace hapticlab::analysis
