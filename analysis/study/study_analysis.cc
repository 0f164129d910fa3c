#include "analysis/study/study_analysis.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include "analysis/stats/balanced_pair.h"
#include "analysis/stats/block_table.h"
#include "analysis/stats/data_error.h"
#include "analysis/stats/durbin.h"
#include "analysis/stats/friedman.h"
#include "analysis/stats/pairwise_friedman.h"
#include "analysis/stats/skillings_mack.h"
#include "analysis/study/sample_reader.h"
#include "db/study_db.h"

namespace hapticlab::analysis {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

const char* measure_column(Measure m) {
  switch (m) {
    case Measure::kForceMedian: return "force_median_N";
    case Measure::kForceP95: return "force_p95_N";
    case Measure::kCompletionTime: return "completion_time_s";
    case Measure::kSpeedMedian: return "speed_median_m_per_s";
    case Measure::kPathLength: return "path_length_m";
  }
  return "?";
}

const char* measure_label(Measure m) {
  switch (m) {
    case Measure::kForceMedian: return "50p force";
    case Measure::kForceP95: return "95p force";
    case Measure::kCompletionTime: return "Time";
    case Measure::kSpeedMedian: return "50p velocity";
    case Measure::kPathLength: return "Path length";
  }
  return "?";
}

const char* measure_unit(Measure m) {
  switch (m) {
    case Measure::kForceMedian:
    case Measure::kForceP95: return "N";
    case Measure::kCompletionTime: return "s";
    case Measure::kSpeedMedian: return "m/s";
    case Measure::kPathLength: return "m";
  }
  return "";
}

bool measure_per_hand(Measure m) { return m != Measure::kCompletionTime; }

const char* hand_name(int hand) { return hand == 0 ? "left" : hand == 1 ? "right" : "both"; }

void AnalysisOptions::validate() const {
  auto fail = [](const std::string& field, const std::string& value, const std::string& range) {
    throw DataError("analysis option " + field + " is " + value + ", but must be " + range);
  };
  if (!(alpha > 0.0 && alpha < 1.0)) fail("alpha", std::to_string(alpha), "> 0 and < 1");
  if (!(std::isfinite(min_force_N) && min_force_N >= 0.0))
    fail("min_force_N", std::to_string(min_force_N), "finite and >= 0 N");
  if (ks_resamples < 1) fail("ks_resamples", std::to_string(ks_resamples), ">= 1");
  if (ks_stride < 1) fail("ks_stride", std::to_string(ks_stride), ">= 1 sample");
  if (ks_block_length < 1) fail("ks_block_length", std::to_string(ks_block_length), ">= 1 sample");
  if (cdf_points < 2) fail("cdf_points", std::to_string(cdf_points), ">= 2");
}

double TrialRecord::value(Measure m, int hand) const {
  if (m == Measure::kCompletionTime) return window ? window->duration_s() : kNaN;
  if (!window) return kNaN;
  const HandMetrics& h = hands.at(static_cast<std::size_t>(hand));
  switch (m) {
    case Measure::kForceMedian: return h.force_median_N;
    case Measure::kForceP95: return h.force_p95_N;
    case Measure::kSpeedMedian: return h.speed_median_m_per_s;
    case Measure::kPathLength: return h.path_length_m;
    case Measure::kCompletionTime: break;
  }
  return kNaN;
}

std::string setting_abbreviation(const std::string& name) {
  std::istringstream words(name);
  std::vector<std::string> parts;
  for (std::string w; words >> w;) parts.push_back(w);
  if (parts.size() < 2) return name;
  std::string out;
  for (const auto& w : parts) out += w == "+" ? '+' : static_cast<char>(std::toupper(static_cast<unsigned char>(w[0])));
  return out;
}

std::string format_p(double p) {
  if (!std::isfinite(p)) return "N/A";
  if (p == 0.0) return "0";
  char buf[32];
  if (p >= 1e-3) {
    std::snprintf(buf, sizeof buf, "%.2g", p);
    return buf;
  }
  // The thesis' style for small p: one digit and a power of ten, "6E-5".
  int exponent = static_cast<int>(std::floor(std::log10(p)));
  double mantissa = std::round(p / std::pow(10.0, exponent));
  if (mantissa >= 10.0) {
    mantissa = 1.0;
    ++exponent;
  }
  std::snprintf(buf, sizeof buf, "%.0fE%d", mantissa, exponent);
  return buf;
}

std::string format_level(double level) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", level);
  return buf;
}

std::string format_p(double p, double level) {
  std::string text = format_p(p);
  if (!std::isfinite(p) || !std::isfinite(level) || p == 0.0) return text;
  const double shown_level = std::strtod(format_level(level).c_str(), nullptr);
  // Trailing zeros kept ("0.007300"), so the digits shown say how close it is.
  const auto rounded = [](double v, int digits) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%#.*g", digits, v);
    return std::string(buf);
  };
  // Readable: on the same side of the level as printed as p is of the level,
  // and not the same text as the level at this precision (0.00729 against
  // 0.0073 must not print as "0.0073").
  const auto readable = [&](const std::string& shown, int digits) {
    const bool below = std::strtod(shown.c_str(), nullptr) < shown_level;
    return below == (p < level) && (p == level || rounded(p, digits) != rounded(level, digits));
  };
  if (readable(text, 2)) return text;
  for (int digits = 3; digits < 17; ++digits) {
    text = rounded(p, digits);
    if (readable(text, digits)) return text;
  }
  return rounded(p, 17);
}

// ---------------------------------------------------------------------------
// Reading the study
// ---------------------------------------------------------------------------
namespace {

std::string normalized(const std::string& name) {
  std::string out;
  for (char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c))) {
      out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (!out.empty() && out.back() != '_') {
      out += '_';
    }
  }
  while (!out.empty() && out.back() == '_') out.pop_back();
  return out;
}

std::optional<TaskEventType> event_type(const std::string& name) {
  for (int i = 0; i < kNumTaskEventTypes; ++i) {
    const auto type = static_cast<TaskEventType>(i);
    if (name == to_string(type)) return type;
  }
  return std::nullopt;  // the runner's and writer's own events do not bound the task
}

std::vector<double> every_kth(const std::vector<double>& values, std::size_t k) {
  std::vector<double> out;
  out.reserve(values.size() / k + 1);
  for (std::size_t i = 0; i < values.size(); i += k) out.push_back(values[i]);
  return out;
}

void mark_missing(TrialRecord& record) {
  for (auto& h : record.hands) {
    h.force_median_N = h.force_p95_N = h.speed_median_m_per_s = h.path_length_m = kNaN;
  }
}

// Sample buffers reused from trial to trial (a trial-hand is ~10^5 samples).
struct ReadBuffers {
  HandSeriesReader reader;
  std::array<HandSeries, 2> series;
};

TrialRecord read_trial(db::StudyDb& db, const db::TrialRow& row, const AnalysisOptions& options,
                       ReadBuffers& buffers) {
  std::array<HandSeries, 2>& series = buffers.series;
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
  for (const db::EventRow& e : db.events(row.id)) {
    if (const auto type = event_type(e.type)) {
      events.push_back({e.t_s, *type, static_cast<std::int8_t>(e.instrument), static_cast<std::int32_t>(e.item_index)});
    }
  }
  double trial_end_s = -std::numeric_limits<double>::infinity();
  for (std::size_t hand = 0; hand < 2; ++hand) {
    buffers.reader.read(db, row.id, static_cast<int>(hand), series[hand]);
    for (const db::BadChunk& c : buffers.reader.bad_chunks()) rec.damaged_chunks.push_back(db::describe(c));
    if (series[hand].size() > 0) trial_end_s = std::max(trial_end_s, series[hand].t_s.back());
  }
  mark_missing(rec);
  if (!rec.damaged_chunks.empty()) {
    rec.problem =
        std::to_string(rec.damaged_chunks.size()) + " damaged sample chunk(s) left out (hapticlab study check)";
    return rec;
  }
  if (series[0].size() == 0 && series[1].size() == 0) {
    rec.problem = "no samples logged";
    return rec;
  }
  const TaskWindowResult window = task_window(events, trial_end_s);
  if (!window.window) {
    rec.problem = window.problem;
    return rec;
  }
  try {
    for (std::size_t hand = 0; hand < 2; ++hand) {
      WindowValues values = window_values(series[hand], *window.window, options.min_force_N);
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
    for (auto* v : {&rec.force_series_N, &rec.speed_series_m_per_s, &rec.force_quantiles_N,
                    &rec.speed_quantiles_m_per_s}) {
      for (auto& x : *v) x.clear();
    }
  }
  return rec;
}

void add_unique(std::vector<std::string>& list, const std::string& value) {
  if (std::find(list.begin(), list.end(), value) == list.end()) list.push_back(value);
}

}  // namespace

StudyAnalysis analyze_study(db::StudyDb& db, const AnalysisOptions& options) {
  options.validate();
  StudyAnalysis a;
  a.options = options;
  a.db_path = db.path();

  // Which study.
  const std::vector<db::StudyRow> studies = db.studies();
  if (studies.empty()) throw DataError(db.path() + ": the database holds no study");
  const db::StudyRow* study = nullptr;
  if (options.study_id) {
    for (const auto& s : studies)
      if (s.id == *options.study_id) study = &s;
    if (study == nullptr) {
      std::string ids;
      for (const auto& s : studies) ids += (ids.empty() ? "" : ", ") + std::to_string(s.id) + " (" + s.name + ")";
      throw DataError("study id is " + std::to_string(*options.study_id) + ", but " + db.path() +
                      " holds only: " + ids);
    }
  } else if (studies.size() == 1) {
    study = &studies.front();
  } else {
    std::string ids;
    for (const auto& s : studies) ids += (ids.empty() ? "" : ", ") + std::to_string(s.id) + " (" + s.name + ")";
    throw DataError(db.path() + " holds " + std::to_string(studies.size()) +
                    " studies; choose one with --study ID: " + ids);
  }
  a.study_id = study->id;
  a.study_name = study->name;
  a.study_seed = study->seed;
  a.study_software_version = study->software_version;
  a.protocol_sha256 = study->protocol_sha256;
  a.study_created_utc = study->created_utc;

  // Trials, and the study's names in a stable order: settings by id (the
  // protocol's order), participants and tasks by first appearance.
  const std::vector<db::TrialRow> rows = db.trials(study->id);
  std::vector<std::pair<std::int64_t, std::string>> setting_ids;
  for (const auto& row : rows) {
    add_unique(a.participants, row.participant_code);
    add_unique(a.tasks, row.task);
    setting_ids.emplace_back(row.setting_id, row.setting_name);
  }
  std::sort(setting_ids.begin(), setting_ids.end());
  setting_ids.erase(std::unique(setting_ids.begin(), setting_ids.end()), setting_ids.end());
  for (const auto& [id, name] : setting_ids) add_unique(a.settings, name);

  // The control: named, or the setting called like "High Fidelity".
  if (!options.control_setting.empty()) {
    if (std::find(a.settings.begin(), a.settings.end(), options.control_setting) == a.settings.end()) {
      std::string names;
      for (const auto& s : a.settings) names += (names.empty() ? "'" : ", '") + s + "'";
      throw DataError("control setting is '" + options.control_setting + "', but the study's settings are: " + names);
    }
    a.control = options.control_setting;
  } else {
    for (const auto& s : a.settings)
      if (normalized(s) == "high_fidelity") a.control = s;
    if (a.control.empty() && !a.settings.empty()) {
      std::string names;
      for (const auto& s : a.settings) names += (names.empty() ? "'" : ", '") + s + "'";
      throw DataError("no setting is named 'High Fidelity'; name the control with --control (settings: " + names + ")");
    }
  }
  if (!a.control.empty()) {
    a.settings.erase(std::find(a.settings.begin(), a.settings.end(), a.control));
    a.settings.insert(a.settings.begin(), a.control);
  }

  ReadBuffers buffers;
  for (const auto& row : rows) {
    const bool aborted = row.status == db::TrialStatus::kAborted;
    if (row.status == db::TrialStatus::kComplete) {
      ++a.counts.complete;
    } else if (aborted && !options.include_aborted) {
      ++a.counts.aborted_excluded;
      continue;
    } else if (aborted) {
      ++a.counts.aborted_included;
    } else {
      ++a.counts.not_run;
      continue;
    }
    a.trials.push_back(read_trial(db, row, options, buffers));
    ++a.counts.analysed;
    if (!a.trials.back().window) ++a.counts.without_window;
    a.counts.damaged_chunks += a.trials.back().damaged_chunks.size();
  }
  run_statistics(a);
  return a;
}

StudyAnalysis analyze_study_file(const std::filesystem::path& db_path, const AnalysisOptions& options) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(db_path, ec)) {
    throw DataError("--db is '" + db_path.string() + "', but no such file exists (expected a study database)");
  }
  db::OpenOptions open;
  open.recover = false;  // reading must never abort a trial another process is running
  // Full check: quick_check does not compare indexes with their tables, and
  // a damaged index silently hides rows from the queries that use it.
  open.integrity = db::OpenOptions::Integrity::kFull;
  db::StudyDb db(db_path, open);
  return analyze_study(db, options);
}

// ---------------------------------------------------------------------------
// Statistics
// ---------------------------------------------------------------------------
namespace {

struct Point {
  std::string block;
  std::string setting;
  int repetition = 0;
  int position = 0;
  double value = 0.0;
};

// Finite values of one measure, for the trials matching the filters
// (empty participant: every participant; hand -1 with a per-hand measure:
// both hands, each its own block "participant/hand").
std::vector<Point> collect(const StudyAnalysis& a, const std::string& participant, const std::string& task,
                           Measure m, int hand) {
  std::vector<Point> out;
  for (const TrialRecord& t : a.trials) {
    if (t.task != task || (!participant.empty() && t.participant != participant)) continue;
    if (!measure_per_hand(m)) {
      const double v = t.value(m, 0);
      if (std::isfinite(v)) out.push_back({t.participant, t.setting, t.repetition, t.position, v});
      continue;
    }
    for (int h = 0; h < 2; ++h) {
      if (hand >= 0 && h != hand) continue;
      const double v = t.value(m, h);
      if (std::isfinite(v)) out.push_back({t.participant + "/" + hand_name(h), t.setting, t.repetition, t.position, v});
    }
  }
  // Replicates in repetition order, so balancing keeps the first ones.
  std::stable_sort(out.begin(), out.end(), [](const Point& x, const Point& y) { return x.repetition < y.repetition; });
  return out;
}

std::vector<std::string> ordered_settings(const StudyAnalysis& a, const std::vector<Point>& points) {
  std::vector<std::string> out;
  for (const auto& s : a.settings)
    if (std::any_of(points.begin(), points.end(), [&](const Point& p) { return p.setting == s; })) out.push_back(s);
  return out;
}

// Friedman with replicates across the settings present, after making the
// design rectangular: settings missing from a block are dropped, and every
// cell keeps its first r repetitions, r the smallest count (MATLAB's
// friedman(X, reps) needs equal replicates).
OptionalTest balanced_friedman(const StudyAnalysis& a, const std::vector<Point>& points) {
  OptionalTest out;
  std::vector<std::string> blocks;
  for (const auto& p : points) add_unique(blocks, p.block);
  std::map<std::pair<std::string, std::string>, std::vector<double>> cells;
  for (const auto& p : points) cells[{p.block, p.setting}].push_back(p.value);
  std::vector<std::string> dropped_settings;
  for (const auto& s : ordered_settings(a, points)) {
    const bool everywhere = std::all_of(blocks.begin(), blocks.end(), [&](const std::string& b) { return cells.count({b, s}) > 0; });
    if (everywhere) {
      out.settings.push_back(s);
    } else {
      dropped_settings.push_back(s);
    }
  }
  if (out.settings.size() < 2) {
    out.note = points.empty() ? "no data" : "fewer than 2 settings with data in every block";
    return out;
  }
  std::size_t r = std::numeric_limits<std::size_t>::max();
  for (const auto& b : blocks)
    for (const auto& s : out.settings) r = std::min(r, cells[{b, s}].size());
  BlockTable table;
  table.block_names = blocks;
  table.treatment_names = out.settings;
  for (const auto& b : blocks) {
    auto& row = table.cells.emplace_back();
    for (const auto& s : out.settings) {
      const auto& v = cells[{b, s}];
      out.dropped += v.size() - r;
      row.emplace_back(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(r));
    }
  }
  for (const auto& s : dropped_settings)
    for (const auto& b : blocks) out.dropped += cells.count({b, s}) ? cells[{b, s}].size() : 0;
  out.replicates = r;
  try {
    out.result = friedman_test(table);
  } catch (const DataError& e) {
    out.note = e.what();
  }
  if (!dropped_settings.empty()) {
    std::string names;
    for (const auto& s : dropped_settings) names += (names.empty() ? "" : ", ") + s;
    out.note += (out.note.empty() ? "" : "; ") + std::string("left out (missing in a block): ") + names;
  }
  return out;
}

double median_of(std::vector<double> v, PercentileMethod method) {
  std::sort(v.begin(), v.end());
  return percentile_sorted(v, 50.0, method);
}

OptionalTest whole_design_test(const StudyAnalysis& a, const std::vector<Point>& points) {
  OptionalTest out;
  std::vector<std::string> blocks;
  for (const auto& p : points) add_unique(blocks, p.block);
  out.settings = ordered_settings(a, points);
  if (out.settings.size() < 2 || blocks.size() < 2) {
    out.note = "needs >= 2 blocks and >= 2 settings";
    return out;
  }
  std::map<std::pair<std::string, std::string>, std::vector<double>> cells;
  for (const auto& p : points) cells[{p.block, p.setting}].push_back(p.value);
  // One value per cell: the median of its repetitions (Durbin and
  // Skillings–Mack take no replicates).
  BlockTable table;
  table.block_names = blocks;
  table.treatment_names = out.settings;
  bool complete = true;
  for (const auto& b : blocks) {
    auto& row = table.cells.emplace_back();
    for (const auto& s : out.settings) {
      auto it = cells.find({b, s});
      if (it == cells.end()) {
        complete = false;
        row.emplace_back();
      } else {
        row.push_back({median_of(it->second, a.options.percentile_method)});
      }
    }
  }
  out.replicates = 1;
  try {
    if (complete) {
      out.result = friedman_test(table);
    } else {
      try {
        out.result = durbin_test(table).chi_square;
      } catch (const DataError&) {
        // Not a balanced incomplete block design: Skillings–Mack takes any pattern.
        out.result = skillings_mack_test(table);
      }
    }
  } catch (const DataError& e) {
    out.note = e.what();
  }
  return out;
}

}  // namespace

void run_statistics(StudyAnalysis& a) {
  a.friedman.clear();
  a.pairwise.clear();
  a.whole_design.clear();
  a.correlations.clear();
  a.ks.clear();
  const AnalysisOptions& o = a.options;

  // Table 3.4: per participant and task, hands as blocks; then each hand alone.
  for (const auto& task : a.tasks) {
    for (const auto& participant : a.participants) {
      const bool did_task = std::any_of(a.trials.begin(), a.trials.end(), [&](const TrialRecord& t) {
        return t.participant == participant && t.task == task;
      });
      if (!did_task) continue;
      for (int hand = -1; hand < 2; ++hand) {
        for (Measure m : kAllMeasures) {
          if (hand >= 0 && !measure_per_hand(m)) continue;
          FriedmanRow row{participant, task, m, hand, {}};
          row.test = balanced_friedman(a, collect(a, participant, task, m, hand));
          a.friedman.push_back(std::move(row));
        }
      }
    }
  }

  // Tables 3.5 / 3.6: the control against each other setting, all blocks that did both.
  a.sidak_m = a.settings.empty() ? 0 : a.settings.size() - 1;
  a.sidak_level = a.sidak_m > 0 ? sidak_level(o.alpha, a.sidak_m) : o.alpha;
  for (const auto& task : a.tasks) {
    for (std::size_t si = 1; si < a.settings.size(); ++si) {
      const std::string& setting = a.settings[si];
      for (Measure m : kAllMeasures) {
        PairwiseCell cell;
        cell.task = task;
        cell.setting = setting;
        cell.measure = m;
        cell.gated = std::none_of(a.friedman.begin(), a.friedman.end(), [&](const FriedmanRow& r) {
          return r.task == task && r.measure == m && r.hand == -1 && r.test.result && r.test.result->p < o.alpha;
        });
        const std::vector<Point> points = collect(a, "", task, m, -1);
        std::vector<Observation> pair_points;
        for (const auto& p : points) {
          if (p.setting == a.control || p.setting == setting) pair_points.push_back({p.block, p.setting, "", p.value});
        }
        // Balanced as `stats pairwise` does: same replicates in every cell.
        const BlockTable both = BlockTable::from_observations(pair_points);
        const BalancedPair balanced =
            both.treatment_count() == 2
                ? balance_pair(both, both.treatment_index(a.control), both.treatment_index(setting))
                : BalancedPair{};
        const BlockTable& table = balanced.table;
        std::set<std::string> participants;
        for (const auto& b : table.block_names) participants.insert(b.substr(0, b.find('/')));
        cell.note = balanced.note();
        cell.blocks = table.block_names.size();
        cell.participants = participants.size();
        if (table.block_names.empty()) {
          cell.note = "no participant has data for both settings";
        } else {
          try {
            const TestResult r = friedman_test(table);
            cell.p = r.p;
            cell.statistic = r.statistic;
            cell.significant = r.p < a.sidak_level;
          } catch (const DataError& e) {
            cell.note = e.what();
          }
        }
        a.pairwise.push_back(std::move(cell));
      }
    }
  }

  // Whole design: every participant at once.
  for (const auto& task : a.tasks) {
    for (Measure m : kAllMeasures) {
      a.whole_design.push_back({task, m, whole_design_test(a, collect(a, "", task, m, -1))});
    }
  }

  // Table 3.7: trial-number correlations.
  for (const auto& task : a.tasks) {
    for (const auto& participant : a.participants) {
      for (Measure m : kAllMeasures) {
        for (int hand = measure_per_hand(m) ? 0 : -1; hand < (measure_per_hand(m) ? 2 : 0); ++hand) {
          CorrelationRow row;
          row.participant = participant;
          row.task = task;
          row.measure = m;
          row.hand = hand;
          for (const TrialRecord& t : a.trials) {
            if (t.participant != participant || t.task != task) continue;
            const double v = t.value(m, std::max(hand, 0));
            if (!std::isfinite(v)) continue;
            row.trial_numbers.push_back(t.position);
            row.values.push_back(v);
            row.settings.push_back(t.setting);
          }
          if (row.values.empty()) continue;  // the participant did not do this task
          if (row.values.size() < 3) {
            row.note = "fewer than 3 trials";
          } else {
            try {
              row.result = pearson_correlation(row.trial_numbers, row.values);
            } catch (const DataError& e) {
              row.note = e.what();
            }
          }
          a.correlations.push_back(std::move(row));
        }
      }
    }
  }

  // Appendix I: KS with the moving block bootstrap, control vs each setting.
  if (!o.ks) return;
  std::uint64_t comparison = 0;
  for (const auto& task : a.tasks) {
    for (int hand = 0; hand < 2; ++hand) {
      for (const char* quantity : {"force", "speed"}) {
        for (std::size_t si = 1; si < a.settings.size(); ++si) {
          ++comparison;
          KsRow row{task, hand, quantity, a.settings[si], std::nullopt, {}};
          std::vector<ParticipantRepetitions> data;
          std::size_t too_short = 0;
          for (const auto& participant : a.participants) {
            ParticipantRepetitions reps;
            reps.participant = participant;
            for (const TrialRecord& t : a.trials) {
              if (t.participant != participant || t.task != task) continue;
              const bool control = t.setting == a.control;
              if (!control && t.setting != row.setting) continue;
              const auto& series = std::string(quantity) == "force" ? t.force_series_N[static_cast<std::size_t>(hand)]
                                                                    : t.speed_series_m_per_s[static_cast<std::size_t>(hand)];
              if (series.size() < o.ks_block_length) {
                if (!series.empty() || t.window) ++too_short;
                continue;
              }
              (control ? reps.control : reps.other).push_back(series);
            }
            if (!reps.control.empty() || !reps.other.empty()) data.push_back(std::move(reps));
          }
          KsBootstrapOptions ko;
          ko.resamples = o.ks_resamples;
          ko.block_length = o.ks_block_length;
          // Each comparison its own reproducible stream.
          ko.seed = o.seed * 0x9E3779B97F4A7C15ULL + comparison;
          ko.percentile_method = o.percentile_method;
          try {
            KsBootstrapResult r = ks_block_bootstrap(data, ko);
            r.d_intra.clear();
            r.d_intra.shrink_to_fit();
            r.d_inter.clear();
            r.d_inter.shrink_to_fit();
            row.result = std::move(r);
          } catch (const DataError& e) {
            row.note = e.what();
          }
          if (too_short > 0) {
            row.note += (row.note.empty() ? "" : "; ") + std::to_string(too_short) +
                        " repetition(s) shorter than the block length left out";
          }
          a.ks.push_back(std::move(row));
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------
// Headline tables
// ---------------------------------------------------------------------------
namespace {

std::string pad(const std::string& s, std::size_t width) {
  // Width in characters, not bytes, so names with UTF-8 stay aligned.
  std::size_t chars = 0;
  for (unsigned char c : s) chars += (c & 0xC0) != 0x80;
  return s + std::string(width > chars ? width - chars : 1, ' ');
}

}  // namespace

std::string format_headline_tables(const StudyAnalysis& a) {
  std::ostringstream out;
  const TrialCounts& c = a.counts;
  out << "Study '" << a.study_name << "' (" << a.db_path.string() << ")\n";
  out << "Trials analysed: " << c.analysed << " (" << c.complete << " complete";
  if (c.aborted_included > 0) out << ", " << c.aborted_included << " aborted included";
  out << "); aborted left out: " << c.aborted_excluded << "; not run: " << c.not_run
      << "; without a task window: " << c.without_window;
  if (c.damaged_chunks > 0) out << " (" << c.damaged_chunks << " damaged sample chunk(s) left out)";
  out << "\n";
  out << "Percentiles: " << percentile_method_name(a.options.percentile_method) << "; alpha = " << a.options.alpha
      << "; control: " << a.control << "\n\n";

  constexpr std::size_t kRowWidth = 26;
  constexpr std::size_t kColWidth = 14;
  out << "Table 3.4  Friedman across settings per participant (hands as blocks, repetitions as replicates): p\n";
  out << pad("", kRowWidth);
  for (Measure m : kAllMeasures) out << pad(measure_label(m), kColWidth);
  out << "\n";
  for (const auto& task : a.tasks) {
    for (const auto& participant : a.participants) {
      std::vector<const FriedmanRow*> rows;
      for (const auto& r : a.friedman)
        if (r.task == task && r.participant == participant && r.hand == -1) rows.push_back(&r);
      if (rows.empty()) continue;
      out << pad(task + " " + participant, kRowWidth);
      for (Measure m : kAllMeasures) {
        std::string cell = "N/A";
        for (const auto* r : rows) {
          if (r->measure == m && r->test.result) {
            cell = format_p(r->test.result->p, a.options.alpha) + (r->test.result->p < a.options.alpha ? "*" : "");
          }
        }
        out << pad(cell, kColWidth);
      }
      out << "\n";
    }
  }
  out << "* p < " << a.options.alpha << "\n\n";

  const std::string level = format_level(a.sidak_level);
  int table_number = 5;
  for (const auto& task : a.tasks) {
    out << "Table 3." << table_number++ << "  " << task << ": " << a.control
        << " compared to (participants): p, significant below the Šidák level " << level << " (m = " << a.sidak_m
        << ")\n";
    out << pad("", kRowWidth);
    for (Measure m : kAllMeasures) out << pad(measure_label(m), kColWidth);
    out << "\n";
    for (std::size_t si = 1; si < a.settings.size(); ++si) {
      std::size_t participants = 0;
      for (const auto& cell : a.pairwise)
        if (cell.task == task && cell.setting == a.settings[si]) participants = std::max(participants, cell.participants);
      out << pad(a.settings[si] + " (" + std::to_string(participants) + ")", kRowWidth);
      for (Measure m : kAllMeasures) {
        std::string text = "N/A";
        for (const auto& cell : a.pairwise) {
          if (cell.task != task || cell.setting != a.settings[si] || cell.measure != m || !cell.p) continue;
          text = format_p(*cell.p, a.sidak_level) + (cell.significant ? "**" : "");
          if (cell.gated) text = "(" + text + ")";
        }
        out << pad(text, kColWidth);
      }
      out << "\n";
    }
    out << "** p < " << level << "; (p): no participant's Table 3.4 test was significant for this measure, "
        << "so the thesis' procedure would not compare\n\n";
  }

  out << "All participants at once (per-cell medians; Friedman if complete, else Durbin or Skillings-Mack): p\n";
  out << pad("", kRowWidth);
  for (Measure m : kAllMeasures) out << pad(measure_label(m), kColWidth);
  out << "\n";
  for (const auto& task : a.tasks) {
    out << pad(task, kRowWidth);
    for (Measure m : kAllMeasures) {
      std::string text = "N/A";
      for (const auto& r : a.whole_design) {
        if (r.task == task && r.measure == m && r.test.result) {
          text = format_p(r.test.result->p, a.options.alpha) + (r.test.result->p < a.options.alpha ? "*" : "");
          text += " " + std::string(r.test.result->method == "Skillings-Mack" ? "SM" : r.test.result->method.substr(0, 1));
        }
      }
      out << pad(text, kColWidth);
    }
    out << "\n";
  }
  out << "F Friedman, D Durbin, SM Skillings-Mack; * p < " << a.options.alpha << "\n";
  return out.str();
}

}  // namespace hapticlab::analysis
