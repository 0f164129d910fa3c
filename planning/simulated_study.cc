#include "planning/simulated_study.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <cstdio>
#include <map>
#include <optional>
#include <stdexcept>
#include <vector>

#include "analysis/study/ordered_names.h"
#include "analysis/study/staircase_progress.h"
#include "analysis/study/statistics_tables.h"
#include "analysis/study/trial_reader.h"
#include "core/sim/trial_runner.h"
#include "db/sample_codec.h"
#include "protocols/loop_protections.h"
#include "protocols/schedule.h"
#include "sessions/session_runner.h"

namespace hapticlab::planning {
namespace {

using analysis::add_unique;

std::string participant_code(int i, int count) {
  char code[16];
  std::snprintf(code, sizeof code, count >= 100 ? "P%03d" : "P%02d", i + 1);
  return code;
}

// What the database keeps of a sample the measures read: position, velocity
// and force as float32 (db/sample_codec.h), so the measures equal those of
// the same study run through `session run` and `analyze`.
struct KeptSample {
  double t_s;
  analysis::Vec3d position_m;
  analysis::Vec3d velocity_m_per_s;
  analysis::Vec3d force_N;
};

analysis::Vec3d as_stored(const Vec3& v) {
  return {db::to_stored_float(v[0]), db::to_stored_float(v[1]), db::to_stored_float(v[2])};
}

}  // namespace

protocols::Protocol resized_protocol(const protocols::Protocol& protocol, int participants, std::uint64_t seed) {
  if (participants < 1 || participants > 999) {
    throw std::invalid_argument("participants: " + std::to_string(participants) + " is outside 1..999");
  }
  if (protocol.participants.empty()) throw std::invalid_argument("participants: the protocol has none");
  protocols::Protocol p = protocol;
  p.seed = seed;
  p.participants.clear();
  std::map<std::string, std::vector<std::string>> assignments;
  const std::size_t m = protocol.participants.size();
  for (int i = 0; i < participants; ++i) {
    protocols::ParticipantSpec spec = protocol.participants[static_cast<std::size_t>(i) % m];
    const std::string old_code = spec.code;
    spec.code = participant_code(i, participants);
    if (protocol.design.type == protocols::DesignType::kExplicit) {
      assignments[spec.code] = protocol.design.assignments.at(old_code);
    }
    p.participants.push_back(std::move(spec));
  }
  if (protocol.design.type == protocols::DesignType::kExplicit) p.design.assignments = std::move(assignments);
  protocols::validate_protocol(p, protocol.study + " with " + std::to_string(participants) + " participants");
  return p;
}

namespace {

// One simulated study run as `session run` would run it, in stages: each
// participant's training, designed trials and staircase; each trial's
// measures accumulated from the samples the database would keep.
class StudySimulator {
 public:
  StudySimulator(const protocols::Protocol& p, const SimulatedStudyOptions& options, SimulatedStudy& out)
      : p_(p), options_(options), out_(out), a_(out.analysis),
        // Training runs under the protocol's first setting, as session run's does.
        training_settings_(p.settings.front().settings.engine) {}

  void run(const protocols::StudyPlan& plan) {
    // Staircase trials come after all the designed ones.
    for (const protocols::ParticipantPlan& pp : plan.participants)
      staircase_id_ += static_cast<std::int64_t>(pp.trials.size());
    a_.staircase = p_.staircase ? std::optional(p_.staircase->spec) : std::nullopt;
    for (const protocols::ParticipantPlan& pp : plan.participants) run_participant(pp);
  }

 private:
  // A participant as the simulation goes: its seed, its complete trials per
  // task (its practice), the tasks it trained.
  struct Participant {
    const protocols::ParticipantPlan& plan;
    std::uint64_t seed;
    std::map<std::string, int> complete_of_task;
    std::map<std::string, bool> trained;
    int last_position = 0;  // of the schedule; staircase trials come after it
  };

  void run_participant(const protocols::ParticipantPlan& pp) {
    Participant who{pp, sessions::participant_seed(p_.seed, pp.code), {}, {}, 0};
    for (const protocols::PlannedTrial& t : pp.trials) who.last_position = std::max(who.last_position, t.position);
    for (const protocols::PlannedTrial& t : pp.trials) {
      ++trial_id_;
      const std::string task(protocols::task_name(t.task));
      if (pp.training_trials > 0 && !who.trained[task]) {
        who.trained[task] = true;
        train(who, task);
      }
      analysis::TrialRecord rec;
      rec.setting = t.setting;
      rec.repetition = t.repetition;
      rec.block = t.block;
      rec.position = t.position;
      if (auto done = simulate(who, task, p_.settings.at(t.setting_index).settings.engine, trial_id_, std::move(rec)))
        a_.trials.push_back(std::move(*done));
    }
    // The staircase, after the schedule, as session run adds it: trial ids
    // after every designed trial, participants in order.
    if (p_.staircase &&
        std::any_of(pp.trials.begin(), pp.trials.end(),
                    [&](const protocols::PlannedTrial& t) { return protocols::task_name(t.task) == p_.staircase->spec.task; }))
      a_.staircases.push_back(run_staircase(who));
  }

  SimTrialConfig config(const Participant& who, const std::string& task, const EngineSettings& settings,
                        std::uint64_t trial_seed, int practice) const {
    SimTrialConfig c;
    c.task = parse_task_kind(task);
    c.settings = settings;
    c.participant_seed = who.seed;
    c.population = options_.population;
    c.trial_seed = trial_seed;
    c.practice_trials = practice;
    c.clock = ClockKind::kVirtual;
    c.rate_Hz = options_.rate_Hz;
    c.max_duration_s = options_.max_trial_s;
    c.safety = protocols::loop_protections(p_);
    return c;
  }

  // The participant's training trials of `task`, before its first trial of it.
  void train(const Participant& who, const std::string& task) {
    for (int k = 0; k < who.plan.training_trials; ++k) {
      SimTrialConfig c = config(who, task, training_settings_, sessions::training_seed(who.seed, task, k), k);
      c.publish_samples = false;
      const SimTrialResult r = run_sim_trial(c);
      out_.updates += r.samples;
      ++out_.training_trials;
    }
  }

  // One trial as session run would run it: its record, or nullopt when it
  // timed out and the analysis leaves aborted trials out.
  std::optional<analysis::TrialRecord> simulate(Participant& who, const std::string& task,
                                                const EngineSettings& settings, std::int64_t id,
                                                analysis::TrialRecord rec) {
    // As session run seeds it (sessions/trial_seeds.h): a designed trial by
    // its row id, a staircase trial by its position.
    const std::uint64_t seed = rec.block == 0 ? sessions::staircase_trial_seed(who.seed, rec.position)
                                              : sessions::trial_seed(who.seed, id);
    const SimTrialConfig c = config(who, task, settings, seed, who.plan.training_trials + who.complete_of_task[task]);
    for (auto& k : kept_) k.clear();
    events_.clear();
    SimTrialSink sink;
    sink.on_event = [&](const TaskEvent& e) { events_.push_back(e); };
    sink.on_sample = [&](const LoopSample& s) {
      for (std::size_t hand = 0; hand < 2; ++hand) {
        const InstrumentSample& x = s.instrument[hand];
        kept_[hand].push_back({s.t_s, as_stored(x.tip_position_m), as_stored(x.tip_velocity_m_per_s),
                               as_stored(x.ve_force_N)});
      }
    };
    const SimTrialResult r = run_sim_trial(c, sink);
    out_.updates += r.samples;
    ++out_.trials_run;
    auto tally = std::find_if(out_.setting_trials.begin(), out_.setting_trials.end(), [&](const SettingTrials& s) {
      return s.task == task && s.setting == rec.setting;
    });
    if (tally == out_.setting_trials.end()) tally = out_.setting_trials.insert(tally, {task, rec.setting, 0, 0});
    ++tally->run;
    if (!r.task_complete) {
      // Timed out (or faulted): session run records it aborted, and the
      // analysis leaves aborted trials out unless told otherwise.
      ++out_.trials_timed_out;
      ++tally->timed_out;
      if (!options_.analysis.include_aborted) {
        ++a_.counts.aborted_excluded;
        return std::nullopt;
      }
    } else {
      ++who.complete_of_task[task];
    }
    rec.trial_id = id;
    rec.participant = who.plan.code;
    rec.task = task;
    rec.status = r.task_complete ? "complete" : "aborted";
    accumulator_.start(events_, options_.analysis);
    for (std::size_t hand = 0; hand < 2; ++hand) {
      for (const KeptSample& k : kept_[hand]) accumulator_.add(hand, k.t_s, k.position_m, k.velocity_m_per_s, k.force_N);
    }
    accumulator_.finish(rec);
    if (options_.force_extremes && r.task_complete && rec.window) out_.force_extremes[id] = force_extremes(rec);
    return rec;
  }

  // The mean and largest contact force of each hand in the trial's window.
  TrialForceExtremes force_extremes(const analysis::TrialRecord& rec) const {
    TrialForceExtremes x;
    for (std::size_t hand = 0; hand < 2; ++hand) {
      double sum = 0.0, largest = 0.0;
      std::size_t n = 0;
      for (const KeptSample& k : kept_[hand]) {
        if (k.t_s < rec.window->start_s || k.t_s > rec.window->end_s) continue;
        const double f = std::sqrt(k.force_N[0] * k.force_N[0] + k.force_N[1] * k.force_N[1] +
                                   k.force_N[2] * k.force_N[2]);
        if (f < options_.analysis.min_force_N) continue;
        sum += f;
        largest = std::max(largest, f);
        ++n;
      }
      x.mean_N[hand] = n > 0 ? sum / static_cast<double>(n) : std::numeric_limits<double>::quiet_NaN();
      x.max_N[hand] = n > 0 ? largest : std::numeric_limits<double>::quiet_NaN();
    }
    return x;
  }

  // One participant's staircase: the rule replayed after each trial, as
  // plan_next_staircase_trial does over the database.
  analysis::StaircaseRow run_staircase(Participant& who) {
    const protocols::StaircaseSpec& spec = p_.staircase->spec;
    const std::string& code = who.plan.code;
    analysis::StaircaseRow row;
    row.participant = code;
    std::vector<double> baseline;
    for (const analysis::TrialRecord& t : a_.trials)
      if (t.participant == code && t.task == spec.task && t.setting == spec.baseline && t.status == "complete")
        if (const double v = analysis::staircase_value(t, spec.measure); std::isfinite(v)) baseline.push_back(v);
    const std::optional<double> base = analysis::staircase_baseline(baseline);
    if (!base) {
      row.note = "no baseline: no complete '" + spec.baseline + "' trial with a " + spec.measure + " above 0";
      return row;
    }
    row.baseline = *base;
    row.baseline_trials = baseline.size();
    std::vector<std::pair<double, double>> steps;
    protocols::StaircaseState state;
    for (int started = 0;; ++started) {
      state = protocols::replay_staircase(spec, *base, steps);
      if (state.finished || started >= 2 * spec.max_trials) break;
      const NamedSettings at = settings_at_strength(p_.staircase->base.settings, spec.field, state.next_strength);
      analysis::TrialRecord rec;
      rec.setting = at.name;
      rec.block = 0;
      // After the last position, as staircase_planner.cc adds it.
      rec.position = ++who.last_position;
      if (auto done = simulate(who, spec.task, at.engine, ++staircase_id_, std::move(rec))) {
        const double v = analysis::staircase_value(*done, spec.measure);
        if (std::isfinite(v)) steps.emplace_back(state.next_strength, v);
      }
    }
    row.trials = state.trials;
    row.reversals = state.reversal_strengths;
    row.finished = true;
    row.stop_reason = state.finished ? state.stop_reason
                                     : std::to_string(2 * spec.max_trials) + " trials started but only " +
                                           std::to_string(steps.size()) + " complete (2 x max_trials)";
    row.threshold = state.threshold;
    return row;
  }

  const protocols::Protocol& p_;
  const SimulatedStudyOptions& options_;
  SimulatedStudy& out_;
  analysis::StudyAnalysis& a_;
  const EngineSettings& training_settings_;
  std::array<std::vector<KeptSample>, 2> kept_;
  std::vector<TaskEvent> events_;
  analysis::TrialAccumulator accumulator_;
  std::int64_t trial_id_ = 0;      // as study create numbers them: participants in order, then schedule order
  std::int64_t staircase_id_ = 0;  // staircase trials come after all of them
};

}  // namespace

SimulatedStudy simulate_study(const protocols::Protocol& protocol, int participants, std::uint64_t seed,
                              const SimulatedStudyOptions& options) {
  options.analysis.validate();
  const protocols::Protocol p = resized_protocol(protocol, participants, seed);
  const protocols::StudyPlan plan = protocols::make_study_plan(p);

  SimulatedStudy out;
  analysis::StudyAnalysis& a = out.analysis;
  a.options = options.analysis;
  a.study_name = p.study;
  for (const protocols::ProtocolSetting& s : p.settings) add_unique(a.settings, s.settings.name);
  // Participants and tasks in order of first appearance, as analyze lists
  // them (by code, then schedule position).
  for (const protocols::ParticipantPlan& pp : plan.participants) {
    add_unique(a.participants, pp.code);
    for (const protocols::PlannedTrial& t : pp.trials) add_unique(a.tasks, std::string(protocols::task_name(t.task)));
  }
  analysis::choose_control(a, options.analysis);
  StudySimulator(p, options, out).run(plan);
  std::stable_sort(a.trials.begin(), a.trials.end(), [](const auto& x, const auto& y) {
    return x.participant < y.participant;  // analyze's order: by code, then position
  });
  for (const analysis::TrialRecord& t : a.trials) {
    ++a.counts.analysed;
    if (t.status == "complete") ++a.counts.complete; else ++a.counts.aborted_included;
    if (!t.window) ++a.counts.without_window;
  }
  analysis::run_statistics(a);
  return out;
}

}  // namespace hapticlab::planning
