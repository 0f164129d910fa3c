#include "analysis/study/study_analysis.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <thread>
#include <utility>

#include "analysis/stats/data_error.h"
#include "analysis/study/ordered_names.h"
#include "analysis/study/dose_response.h"
#include "analysis/study/staircase_progress.h"
#include "protocols/protocol.h"
#include "protocols/protocol_json.h"
#include "analysis/study/statistics_tables.h"
#include "analysis/study/trial_reader.h"
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

const char* comparison_method_name(ComparisonMethod m) {
  return m == ComparisonMethod::kThesis ? "thesis" : "participant";
}

ComparisonMethod parse_comparison_method(const std::string& name) {
  if (name == "participant") return ComparisonMethod::kParticipant;
  if (name == "thesis") return ComparisonMethod::kThesis;
  throw DataError("method is '" + name + "'; it must be 'participant' (one value per participant, sign-flip test) "
                  "or 'thesis' (the thesis' pairwise Friedman)");
}

void AnalysisOptions::validate() const {
  auto fail = [](const std::string& field, const std::string& value, const std::string& range) {
    throw DataError("analysis option " + field + " is " + value + ", but must be " + range);
  };
  if (!(alpha > 0.0 && alpha < 1.0)) fail("alpha", std::to_string(alpha), "> 0 and < 1");
  if (!(std::isfinite(min_force_N) && min_force_N >= 0.0))
    fail("min_force_N", std::to_string(min_force_N), "finite and >= 0 N");
  if (ks_resamples < kMinKsResamples)
    fail("ks_resamples", std::to_string(ks_resamples), ">= " + std::to_string(kMinKsResamples) +
                                                          " (fewer give a 95 % range of only the extremes)");
  if (ks_stride < 1) fail("ks_stride", std::to_string(ks_stride), ">= 1 sample");
  if (ks_block_length < 1) fail("ks_block_length", std::to_string(ks_block_length), ">= 1 sample");
  if (cdf_points == 1) fail("cdf_points", std::to_string(cdf_points), "0 (no CDF quantiles) or >= 2");
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

// ---------------------------------------------------------------------------
// Reading the study
// ---------------------------------------------------------------------------
void choose_control(StudyAnalysis& a, const AnalysisOptions& options, std::string_view remedy) {
  if (!options.control_setting.empty()) {
    if (std::find(a.settings.begin(), a.settings.end(), options.control_setting) == a.settings.end()) {
      std::string names;
      for (const auto& s : a.settings) names += (names.empty() ? "'" : ", '") + s + "'";
      throw DataError("control setting is '" + options.control_setting + "', but the study's settings are: " + names);
    }
    a.control = options.control_setting;
  } else {
    for (const auto& s : a.settings) {
      if (protocols::control_name_key(s) != "high_fidelity") continue;
      // Two candidates (a file made before protocols refused such names):
      // which one is the control is the user's to say, not the last one's.
      if (!a.control.empty())
        throw DataError("settings '" + a.control + "' and '" + s + "' are both named 'High Fidelity' (ignoring case, "
                        "spaces and punctuation), so neither is known to be the control; " + std::string(remedy));
      a.control = s;
    }
    if (a.control.empty() && !a.settings.empty()) {
      std::string names;
      for (const auto& s : a.settings) names += (names.empty() ? "'" : ", '") + s + "'";
      throw DataError("no setting is named 'High Fidelity' (settings: " + names + "); " + std::string(remedy));
    }
  }
  if (!a.control.empty()) {
    a.settings.erase(std::find(a.settings.begin(), a.settings.end(), a.control));
    a.settings.insert(a.settings.begin(), a.control);
  }
}

namespace {

// Each participant's staircase, when the protocol has one.
void read_staircases(db::StudyDb& db, const db::StudyRow& study, const std::vector<db::TrialRow>& rows,
                     StudyAnalysis& a) {
  a.staircase = protocols::staircase_from_protocol_text(study.protocol_json, db.path() + ": the study's protocol");
  if (!a.staircase) return;
  std::vector<std::pair<std::string, std::int64_t>> who;
  for (const db::TrialRow& row : rows)
    if (std::find_if(who.begin(), who.end(), [&](const auto& w) { return w.second == row.participant_id; }) == who.end())
      who.emplace_back(row.participant_code, row.participant_id);
  for (const auto& [code, id] : who) {
    StaircaseRow r;
    r.participant = code;
    try {
      const std::optional<StaircaseProgress> p = staircase_progress(db, study, id);
      if (!p) continue;  // not in the staircase's task
      r.baseline = p->baseline;
      r.baseline_trials = p->baseline_trials;
      r.trials = p->state.trials;
      r.reversals = p->state.reversal_strengths;
      r.finished = p->state.finished;
      r.stop_reason = p->state.stop_reason;
      r.threshold = p->state.threshold;
    } catch (const StaircaseBaselineError& e) {
      r.note = e.what();
    }
    a.staircases.push_back(std::move(r));
  }
}

// What the stored protocol adds to the trials: its staircase (each
// participant's) and its between-group design.
void read_protocol_parts(db::StudyDb& db, const db::StudyRow& study, const std::vector<db::TrialRow>& rows,
                         StudyAnalysis& a) {
  read_staircases(db, study, rows, a);
  a.group_design = protocols::group_design_from_protocol_text(study.protocol_json, db.path() + ": the study's protocol");
}

}  // namespace

namespace {

// Each participant's site, from the sites of their sessions (a merge
// stamps them; one participant's sessions come from one site, and a file
// edited to say otherwise shows both, "a+b").
void read_sites(db::StudyDb& db, StudyAnalysis& a) {
  db::Statement s = db.connection().prepare(
      "SELECT p.code, s.site FROM session s JOIN participant p ON p.id = s.participant_id "
      "WHERE p.study_id = ?1 AND s.site IS NOT NULL GROUP BY p.code, s.site ORDER BY p.code, s.site");
  s.bind(1, a.study_id);
  while (s.step()) {
    std::string& site = a.participant_sites[s.column_text(0)];
    site += (site.empty() ? "" : "+") + s.column_text(1);
  }
  if (!a.participant_sites.empty()) a.site_balance = site_balance(a.trials, a.participant_sites, a.tasks, a.settings);
}

// Which study: the one chosen by id, or the file's only one.
const db::StudyRow* chosen_study(db::StudyDb& db, const std::vector<db::StudyRow>& studies,
                                 const AnalysisOptions& options) {
  if (studies.empty()) throw DataError(db.path() + ": the database holds no study");
  if (options.study_id) {
    for (const auto& s : studies)
      if (s.id == *options.study_id) return &s;
    std::string ids;
    for (const auto& s : studies) ids += (ids.empty() ? "" : ", ") + std::to_string(s.id) + " (" + s.name + ")";
    throw DataError("study id is " + std::to_string(*options.study_id) + ", but " + db.path() +
                    " holds only: " + ids);
  }
  if (studies.size() == 1) return &studies.front();
  std::string ids;
  for (const auto& s : studies) ids += (ids.empty() ? "" : ", ") + std::to_string(s.id) + " (" + s.name + ")";
  throw DataError(db.path() + " holds " + std::to_string(studies.size()) +
                  " studies; choose one with --study ID: " + ids);
}

}  // namespace

StudyAnalysis analyze_study(db::StudyDb& db, const AnalysisOptions& options) {
  options.validate();
  StudyAnalysis a;
  a.options = options;
  a.db_path = db.path();

  const std::vector<db::StudyRow> studies = db.studies();
  const db::StudyRow* study = chosen_study(db, studies, options);
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
    // A staircase's trials each have a strength of their own: not settings
    // of the design, so not in its comparisons.
    if (row.block != 0) setting_ids.emplace_back(row.setting_id, row.setting_name);
  }
  std::sort(setting_ids.begin(), setting_ids.end());
  setting_ids.erase(std::unique(setting_ids.begin(), setting_ids.end()), setting_ids.end());
  for (const auto& [id, name] : setting_ids) add_unique(a.settings, name);

  choose_control(a, options);
  std::vector<std::pair<std::string, std::string>> settings_json;
  for (const auto& [id, name] : setting_ids) settings_json.emplace_back(name, db.setting_json(id));
  a.dose = find_dose_series(study->protocol_json, a.control, settings_json);

  std::vector<db::TrialRow> analysed;
  for (const auto& row : rows) {
    if (row.block == 0) {
      ++a.counts.staircase;
      continue;
    }
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
    analysed.push_back(row);
  }
  a.trials = read_trials(db, analysed, options, options.threads);
  for (const TrialRecord& t : a.trials) {
    ++a.counts.analysed;
    if (!t.window) ++a.counts.without_window;
    a.counts.damaged_chunks += t.damaged_chunks.size();
  }
  run_statistics(a);
  read_protocol_parts(db, *study, rows, a);
  read_sites(db, a);
  a.session_conditions = read_session_conditions(db, a.study_id);
  // Every comparison is with the control: without a trial of it that has
  // measures, each is N/A, and the tables alone would not say why.
  if (!a.control.empty() && std::none_of(a.trials.begin(), a.trials.end(), [&](const TrialRecord& t) {
        return t.setting == a.control && t.window.has_value();
      }))
    a.session_conditions.warnings.push_back("the control '" + a.control +
                                            "' has no analysed trial with measures (none complete, or none with a "
                                            "task window), so every comparison with it is N/A");
  return a;
}

StudyAnalysis analyze_study_file(const std::filesystem::path& db_path, const AnalysisOptions& options) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(db_path, ec)) {
    throw DataError("--db is '" + db_path.string() + "', but no such file exists (expected a study database)");
  }
  db::OpenOptions open;
  open.recover = false;  // reading must never abort a trial another process is running
  open.integrity = db::OpenOptions::Integrity::kSkip;
  open.mmap_bytes = db::kBulkReadMmapBytes;
  db::StudyDb db(db_path, open);  // migrates an old file first
  // The full check (quick_check does not compare indexes with their tables,
  // and a damaged index silently hides rows from the queries that use it)
  // runs on its own connection while the trials are read, not before them;
  // damage it finds fails the analysis just the same, and is named in place
  // of whatever the damage made the analysis trip over.
  std::exception_ptr damage;
  std::thread check([&] {
    try {
      db::OpenOptions check_open;
      check_open.recover = false;
      check_open.read_only = true;
      check_open.integrity = db::OpenOptions::Integrity::kFull;
      check_open.mmap_bytes = db::kBulkReadMmapBytes;
      db::StudyDb checked(db_path, check_open);
    } catch (...) {
      damage = std::current_exception();
    }
  });
  std::optional<StudyAnalysis> result;
  std::exception_ptr failure;
  try {
    result = analyze_study(db, options);
  } catch (...) {
    failure = std::current_exception();
  }
  check.join();
  if (damage) std::rethrow_exception(damage);
  if (failure) std::rethrow_exception(failure);
  return std::move(*result);
}

}  // namespace hapticlab::analysis
