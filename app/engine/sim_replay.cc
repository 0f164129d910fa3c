#include "app/engine/sim_replay.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "app/cli/cli_checks.h"
#include "app/cli/interrupt_flag.h"
#include "app/cli/renamed_option.h"
#include "app/engine/sim_run.h"
#include "core/common/output_file.h"
#include "core/settings/settings_json.h"
#include "core/sim/trial_runner.h"
#include "db/replay_frames.h"
#include "db/study_db.h"
#include "protocols/loop_protections.h"
#include "sessions/session_runner.h"
#include "app/cli/option_shapes.h"
#include "core/common/csv_format.h"

namespace hapticlab::app {
namespace {

struct SimReplayOptions {
  std::string db;
  std::optional<std::int64_t> trial;
  std::string csv;
  std::string task;
  std::string settings;
  std::optional<std::uint64_t> trial_seed;
  std::optional<double> rate_Hz;  // default: the recording's (recorded_rate_Hz), else 1 kHz
  std::string output;
};

// What to replay, resolved from the options: the motion, the task and its
// layout seed, and the setting.
struct Recording {
  std::vector<ReplayFrame> frames;
  std::string task;
  std::uint64_t trial_seed = 1;
  NamedSettings settings;
  std::string what;  // for the summary line
  std::optional<double> recorded_rate_Hz;  // a database trial's loop rate
  // A database trial's: its study's force limits (the logged commands are
  // the limited ones); a CSV's: the defaults.
  LoopSafetyConfig protections;
};

// The loop rate a trial was recorded at: the median period between its
// updates, as a whole number of hertz, within the loop's 150..2000 Hz. The
// median, because a wall-clock recording's periods jitter and a few late
// updates must not move it. Replayed at another rate, the engine's filters
// and the VE step differently from the session's, and a replay through
// the trial's own setting no longer gives back its forces.
std::optional<double> recorded_rate_Hz(const std::vector<ReplayFrame>& frames) {
  std::vector<double> periods_s;
  periods_s.reserve(frames.size());
  for (std::size_t k = 1; k < frames.size(); ++k)
    if (frames[k].t_s > frames[k - 1].t_s) periods_s.push_back(frames[k].t_s - frames[k - 1].t_s);
  if (periods_s.empty()) return std::nullopt;
  auto middle = periods_s.begin() + static_cast<std::ptrdiff_t>(periods_s.size() / 2);
  std::nth_element(periods_s.begin(), middle, periods_s.end());
  return std::clamp(std::round(1.0 / *middle), 150.0, 2000.0);
}

Recording from_database(const SimReplayOptions& opt) {
  db::OpenOptions open;
  open.read_only = true;  // a session may be running
  open.integrity = db::OpenOptions::Integrity::kFull;  // quick_check misses a damaged index
  db::StudyDb db(opt.db, open);
  Recording r;
  // The study holding the trial: its seed gives the simulated trial's task
  // layout exactly as the session runner derived it.
  for (const db::StudyRow& study : db.studies()) {
    const std::vector<db::TrialRow> trials = db.trials(study.id);
    for (const db::TrialRow& t : trials) {
      if (t.id != *opt.trial) continue;
      r.frames = db::load_replay_frames(db, t.id);  // throws for a trial without samples
      r.recorded_rate_Hz = recorded_rate_Hz(r.frames);
      r.protections = protocols::loop_protections_from_protocol_text(study.protocol_json, opt.db);
      r.task = t.task;
      std::vector<db::TrialRow> participants_trials;
      for (const db::TrialRow& other : trials)
        if (other.participant_code == t.participant_code) participants_trials.push_back(other);
      r.trial_seed = opt.trial_seed.value_or(sessions::scheduled_trial_seed(
          sessions::participant_seed(study.seed, t.participant_code), t, participants_trials));
      r.settings = opt.settings.empty() ? db.setting(t.setting_id) : load_settings_file(opt.settings);
      r.what = "trial " + std::to_string(t.id) + " (" + t.participant_code + ", " + t.task + ", recorded with " +
               t.setting_name + ")";
      return r;
    }
  }
  throw std::invalid_argument("--trial: " + std::to_string(*opt.trial) + " is not a trial in " + opt.db);
}

Recording from_csv(const SimReplayOptions& opt) {
  if (opt.task.empty()) throw std::invalid_argument("--task: required with --csv (dissection or clip)");
  if (opt.settings.empty()) throw std::invalid_argument("--settings: required with --csv");
  Recording r;
  r.frames = load_replay_frames_from_trajectory_csv(opt.csv);
  r.task = opt.task;
  r.trial_seed = opt.trial_seed.value_or(1);
  r.settings = load_settings_file(opt.settings);
  r.what = opt.csv;
  return r;
}

int run(const SimReplayOptions& opt) {
  if (opt.db.empty() == opt.csv.empty())
    throw std::invalid_argument("give either --db with --trial, or --csv with --task and --settings");
  if (!opt.db.empty() && !opt.trial) throw std::invalid_argument("--trial: required with --db");
  // Refused rather than ignored: a database trial has its own task, and a
  // CSV holds one recording.
  if (!opt.db.empty() && !opt.task.empty())
    throw std::invalid_argument("--task: not with --db (the trial's own task, recorded in the study, is replayed)");
  if (!opt.csv.empty() && opt.trial) throw std::invalid_argument("--trial: only with --db (a CSV is one recording)");
  // Replacing the database by the output would lose the study.
  for (const auto& [input, option] : {std::pair{&opt.db, "--db"}, {&opt.csv, "--csv"}, {&opt.settings, "--settings"}})
    if (!input->empty()) refuse_output_over_input(*input, opt.output, option, "--out");
  Recording rec = opt.db.empty() ? from_csv(opt) : from_database(opt);

  SimTrialConfig config;
  config.task = parse_task_kind(rec.task);
  config.settings = rec.settings.engine;
  config.trial_seed = rec.trial_seed;
  config.safety = rec.protections;
  config.rate_Hz = opt.rate_Hz.value_or(rec.recorded_rate_Hz.value_or(1000.0));
  const char* rate_source = opt.rate_Hz ? "" : rec.recorded_rate_Hz ? ", the recording's rate" : ", the default";
  // The whole recording, and a little more: the loop ends at its last frame.
  const double recording_s = rec.frames.back().t_s - rec.frames.front().t_s;
  // A CSV longer than any trial may last is a t_s in other units
  // (milliseconds), not a trial: replayed, it wrote without end (2.5 GB in
  // 30 s for one spanning 1e6 s). A stored trial's t_s is the loop's own,
  // in seconds, and as long as its study's limit let it run (which may
  // have been above 3600 s before that option had a range).
  if (!opt.csv.empty() && !(recording_s <= kMaxTrialLimit_s)) {
    throw std::invalid_argument(rec.what + ": the recording spans " + format_number(recording_s) +
                                " s, more than the " + format_number(kMaxTrialLimit_s) +
                                " s a trial may last (--max-trial-s); is t_s in seconds?");
  }
  config.max_duration_s = recording_s + 1.0;
  config.stop_when_complete = false;
  config.replay = std::make_shared<const std::vector<ReplayFrame>>(std::move(rec.frames));

  InterruptFlag interrupt;  // as sim run's: Ctrl-C leaves no temporary file
  const SimTrialResult r = run_sim_trial_to_csv(config, opt.output, interrupt.flag());
  if (r.stop_reason == StopReason::kStopRequested) return report_stopped("sim replay", r, opt.output);

  std::printf("replayed %s through %s at %g Hz%s: %.2f s of %.2f s recorded (%s), task %s, %llu samples, "
              "peak VE force left %.2f N right %.2f N%s -> %s\n",
              rec.what.c_str(), rec.settings.name.c_str(), config.rate_Hz, rate_source, r.duration_s, recording_s,
              to_string(r.stop_reason),
              r.task_complete ? "complete" : "not complete", static_cast<unsigned long long>(r.samples),
              r.peak_ve_force_N[0], r.peak_ve_force_N[1], r.dropped_samples > 0 ? " (SAMPLES DROPPED)" : "",
              opt.output.c_str());
  if (r.stop_reason == StopReason::kDeviceFault) {
    std::fprintf(stderr, "hapticlab sim replay: the recording has a bad reading: %s\n", to_string(r.device_status));
    return 3;
  }
  if (r.stop_reason == StopReason::kWatchdog) {
    std::fprintf(stderr, "hapticlab sim replay: watchdog: %s (docs/safety.md)\n", describe(r.safety_trip).c_str());
    return 3;
  }
  return 0;
}

}  // namespace

void add_sim_replay_command(CLI::App& sim) {
  auto opt = std::make_shared<SimReplayOptions>();
  CLI::App* cmd = sim.add_subcommand(
      "replay",
      "Play a recorded motion (a trial in a study database, or an engine trajectory CSV) through the "
      "degradation engine and a task VE, with no participant: the same hand motion under another "
      "setting. Writes every loop update to a CSV file (the columns of `sim run`) and prints a "
      "summary. The positions are replayed open loop: the recorded hand does not react to the new "
      "forces. Exit status 0 when the recording was played, 3 when it holds a non-finite reading, 130 when "
      "stopped by Ctrl-C (nothing is written then).");
  cmd->add_option("--db", opt->db, "Study database holding the recorded trial")->check(CLI::ExistingFile);
  cmd->add_option("--trial", opt->trial, "Trial id in --db (hapticlab study show / export list them)");
  cmd->add_option("--csv", opt->csv, "Engine trajectory CSV instead of a database trial (docs/engine.md)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--task", opt->task, "Task VE for --csv: dissection or clip (a database trial knows its own)")
      ->check(CLI::IsMember({"dissection", "clip"}));
  cmd->add_option("--settings", opt->settings,
                  "Engine settings file to replay through (default for a database trial: its own setting)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--trial-seed", opt->trial_seed,
                  "Task layout seed (default for a database trial: the one its simulated session used; "
                  "for --csv: 1)")
      ->check(seed_number());
  cmd->add_option("--rate-hz", opt->rate_Hz,
                  "Haptic loop rate [Hz], 150..2000 (default for a database trial: the rate it was recorded at, "
                  "from its median update period; for --csv: 1000)")
      ->check(number_in(150.0, 2000.0));
  CLI::Option* out = cmd->add_option("--out", opt->output, "CSV file to write (one row per loop update); required");
  const RenamedOption out_option = add_old_spelling(*cmd, out, "--output", opt->output);
  cmd->callback([opt, out_option] {
    out_option.require();
    const int status = run(*opt);
    if (status != 0) throw CLI::RuntimeError(status);
  });
}

}  // namespace hapticlab::app
