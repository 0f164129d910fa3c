#include "app/engine/engine_replay.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "core/engine/engine.h"
#include "core/engine/status.h"
#include "app/cli/renamed_option.h"
#include "core/common/csv_format.h"
#include "core/common/output_file.h"
#include "core/device/trajectory_csv.h"
#include "core/settings/settings_json.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

struct ReplayOptions {
  std::string settings;
  std::string input;
  std::string output;
};


// Each instrument's first finite position, so the engine (and any position
// latency it emulates) starts where the recording starts rather than at the
// default pose. A separate pass keeps memory constant; it stops as soon as
// both instruments have been seen.
std::array<JointVector, kNumInstruments> first_positions(const fs::path& input) {
  std::array<JointVector, kNumInstruments> start = {JointVector(0.1, 0.0, 0.0),
                                                    JointVector(0.1, 0.0, 0.0)};
  std::array<bool, kNumInstruments> found{};
  TrajectoryCsvReader reader(input);
  TrajectoryRow row;
  while (!(found[0] && found[1]) && reader.next(row)) {
    if (found[row.instrument] || !row.position.allFinite()) continue;
    start[row.instrument] = row.position;
    found[row.instrument] = true;
  }
  return start;
}

// The median of the time steps, for a message (they are taken by value).
double median_step_s(std::vector<double> v) {
  const auto middle = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), middle, v.end());
  return *middle;
}

// A recording whose rows mostly come more than the engine can bridge apart
// (kMaxSubsteps·kMaxDt_s = 8/150 s, named so in the messages) has every
// such row re-anchored: the models start again from rest at it and no
// degradation acts. That is what a t_s in milliseconds, or a 10 Hz log,
// does; the output would be the VE force undegraded (0 N through a
// saturation), so it is refused, and a few gaps are counted in the summary.
static_assert(kMaxSubsteps == 8 && kMaxDt_s == 1.0 / 150.0, "the messages below say 8/150 s");
void refuse_mostly_gaps(const std::string& input, long long gap_rows, const std::vector<double>& dts_s) {
  if (gap_rows == 0 || 2 * gap_rows <= static_cast<long long>(dts_s.size())) return;
  throw std::runtime_error(
      "--csv " + input + ": " + std::to_string(gap_rows) + " of the " + std::to_string(dts_s.size()) +
      " rows after each instrument's first come more than 8/150 s (53.3 ms) after that instrument's "
      "previous row, so the engine re-anchors at each and no "
      "degradation acts on them (the median time step is " + format_number(median_step_s(dts_s)) +
      " s). Is t_s in seconds? The engine runs at 150..2000 updates per second");
}

// Two finite times can be an infinite step apart (-1e308, then 1e308): the
// engine would take it for a non-finite input.
void refuse_infinite_step(const std::string& input, int instrument, double from_s, double to_s) {
  if (std::isfinite(to_s - from_s)) return;
  throw std::runtime_error("--csv " + input + ": instrument " + std::to_string(instrument) + "'s t_s goes from " +
                           format_number(from_s) + " to " + format_number(to_s) + ", a step too large for a double");
}

void print_summary(const ReplayOptions& opt, const std::array<long long, kNumInstruments>& rows,
                   double peak_force_N, long long fault_rows, long long gap_rows) {
  const std::string gaps =
      gap_rows == 0 ? ""
                    : ", " + std::to_string(gap_rows) + " rows re-anchored after a gap of more than 8/150 s";
  std::printf(
      "%s: %lld rows (instrument 0: %lld, instrument 1: %lld), peak |displayed force| %.4g N, "
      "%lld rows with faults%s -> %s\n",
      opt.input.c_str(), rows[0] + rows[1], rows[0], rows[1], peak_force_N, fault_rows, gaps.c_str(),
      opt.output.c_str());
  std::fflush(stdout);
}

void run_replay(const ReplayOptions& opt) {
  // Read twice (the first pass finds the starting poses): a pipe's second
  // read would start where the first one stopped.
  if (!fs::is_regular_file(opt.input)) {
    throw std::runtime_error("--csv " + opt.input +
                             ": not a regular file (a pipe or a device); engine replay reads it twice, "
                             "the first time for each instrument's starting pose: save it to a file first");
  }
  refuse_output_over_input(opt.input, opt.output, "--csv", "--out");
  refuse_output_over_input(opt.settings, opt.output, "--settings", "--out");
  const NamedSettings settings = load_settings_file(opt.settings);
  Engine engine(settings.engine, first_positions(opt.input));
  TrajectoryCsvReader reader{fs::path(opt.input)};
  AtomicOutputFile output(opt.output);
  TrajectoryCsvWriter writer(output.stream());

  // dt is per instrument: rows of the other instrument in between do not
  // advance this one's time. The first row of each has dt = 0 (the engine
  // anchors its models there).
  std::array<double, kNumInstruments> last_t_s{};
  std::array<bool, kNumInstruments> started{};
  std::array<long long, kNumInstruments> rows{};
  double peak_force_N = 0.0;
  long long fault_rows = 0;
  long long gap_rows = 0;      // more than the engine can bridge after the instrument's previous row
  std::vector<double> dts_s;  // of every row but each instrument's first

  TrajectoryRow row;
  while (reader.next(row)) {
    const int i = row.instrument;
    InstrumentInput in;
    in.dt_s = started[i] ? row.t_s - last_t_s[i] : 0.0;
    if (started[i]) {
      refuse_infinite_step(opt.input, i, last_t_s[i], row.t_s);
      dts_s.push_back(in.dt_s);
      if (in.dt_s > kMaxSubsteps * kMaxDt_s) ++gap_rows;
    }
    in.position = row.position;
    in.ve_force_N = row.ve_force_N;
    started[i] = true;
    last_t_s[i] = row.t_s;

    const InstrumentOutput out = engine.update(i, in);
    try {
      writer.write(row, out);
    } catch (const TrajectoryCsvError&) {
      output.check();  // the writer's message lacks the path and the cause
      throw;
    }
    ++rows[i];
    peak_force_N = std::max(peak_force_N, out.displayed_force_N.norm());
    if (out.status & kFaultMask) ++fault_rows;
  }
  if (rows[0] + rows[1] == 0) {
    throw std::runtime_error("--csv " + opt.input + ": a header and no rows: nothing to replay");
  }
  refuse_mostly_gaps(opt.input, gap_rows, dts_s);
  output.commit();
  print_summary(opt, rows, peak_force_N, fault_rows, gap_rows);
}

}  // namespace

void add_engine_replay_command(CLI::App& engine) {
  auto opt = std::make_shared<ReplayOptions>();
  CLI::App* cmd = engine.add_subcommand(
      "replay",
      "Run a recorded trajectory through the engine, offline, and write what it displays. "
      "Rows are processed in file order; each instrument keeps its own state, and its dt is "
      "the time since its own previous row (0 for its first row).");
  cmd->add_option("--settings", opt->settings, "Settings JSON file")
      ->required()
      ->check(CLI::ExistingFile);
  CLI::Option* csv = cmd->add_option("--csv", opt->input,
                  "Trajectory CSV with a header row and the columns (any order) t_s, "
                  "instrument (0 or 1), insertion_m, pitch_rad, yaw_rad, ve_force_x_N, "
                  "ve_force_y_N, ve_force_z_N; required (a file, not a pipe: it is read twice)")
      ->check(CLI::ExistingFile);
  const RenamedOption csv_option = add_old_spelling(*cmd, csv, "--input", opt->input);
  csv_option.old->check(CLI::ExistingFile);
  CLI::Option* out = cmd->add_option("--out", opt->output,
                  "Output CSV: the input columns, then displayed_force_{x,y,z}_N, "
                  "insertion_force_N, pitch_torque_Nm, yaw_torque_Nm, degraded_insertion_m, "
                  "degraded_pitch_rad, degraded_yaw_rad, fault (status bits). Written to "
                  "OUTPUT.<pid>.tmp and renamed when complete, so a failed replay leaves no "
                  "OUT; must not be the input file; required");
  const RenamedOption out_option = add_old_spelling(*cmd, out, "--output", opt->output);
  cmd->footer(
      "Sign conventions: world frame at the trocar, z up out of the patient; at zero pitch and "
      "yaw the tool points along -z. VE and displayed forces act on the tool tip in the world "
      "frame. A positive insertion force pushes toward larger insertion; positive pitch/yaw "
      "torques turn toward larger angles.");
  cmd->callback([opt, csv_option, out_option] {
    csv_option.require();
    out_option.require();
    run_replay(*opt);
  });
}

}  // namespace hapticlab::app
