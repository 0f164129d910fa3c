// `hapticlab engine demo`: a short demonstration of the degradation engine. Both
// instruments follow a scripted two-handed motion against a soft tissue VE
// while the VE update rate wanders between 200 and 2000 Hz, as the thesis'
// did. The same motion is felt through each shipped setting; one CSV per
// setting (the `engine replay` output format) and a summary table come out.
#include "app/engine/engine_demo.h"
#include "app/cli/cli_checks.h"
#include "app/cli/data_paths.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iterator>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/engine/engine.h"
#include "core/engine/status.h"
#include "core/common/output_file.h"
#include "core/device/trajectory_csv.h"
#include "core/settings/settings_json.h"
#include "planning/plan_folder.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

// The thesis' eight study settings in Table 3.1 order, then the maximum stable set.
const char* const kSettingFiles[] = {"high_fidelity", "no_force_feedback", "inertia",
                                     "inertia_backlash", "friction", "cogging",
                                     "force_saturation", "all_degradations", "max_stable"};

// "high_fidelity.json, no_force_feedback.json, ..." for --help and errors.
std::string setting_file_names(const std::vector<std::string>& files) {
  std::string out;
  for (const std::string& f : files) out += (out.empty() ? "" : ", ") + f + ".json";
  return out;
}

std::string all_setting_file_names() {
  return setting_file_names(std::vector<std::string>(std::begin(kSettingFiles), std::end(kSettingFiles)));
}

// Every settings file the demo feels the motion through, read before
// anything is printed or written: a folder without some is refused naming
// each missing file, not found at the first one after half the CSVs.
std::vector<NamedSettings> load_demo_settings(const fs::path& dir, bool given) {
  const std::string where =
      given ? "--settings-dir '" + dir.string() + "'" : "the shipped settings folder '" + dir.string() + "'";
  const std::size_t count = std::size(kSettingFiles);
  if (!fs::is_directory(dir))
    throw std::runtime_error(where + " is not a folder; it must hold the " + std::to_string(count) +
                             " settings files the demo needs: " + all_setting_file_names());
  std::vector<std::string> missing;
  for (const char* file : kSettingFiles)
    if (!fs::is_regular_file(dir / (std::string(file) + ".json"))) missing.push_back(file);
  if (!missing.empty())
    throw std::runtime_error(where + ": " + std::to_string(missing.size()) + " of the " + std::to_string(count) +
                             " settings files the demo needs are missing: " + setting_file_names(missing) +
                             " (it needs " + all_setting_file_names() + ")");
  std::vector<NamedSettings> settings;
  for (const char* file : kSettingFiles) settings.push_back(load_settings_file(dir / (std::string(file) + ".json")));
  return settings;
}

// Scripted hands: the right instrument probes in and out, the left one holds
// tissue with small corrections. Joints: insertion m, pitch rad, yaw rad.
JointVector hand(int instrument, double t_s) {
  const double w = 2 * std::numbers::pi;
  if (instrument == 1) {
    return {0.115 + 0.012 * std::sin(w * 0.8 * t_s), 0.15 + 0.08 * std::sin(w * 0.35 * t_s),
            -0.10 + 0.06 * std::sin(w * 0.5 * t_s + 1.0)};
  }
  return {0.122 + 0.003 * std::sin(w * 0.3 * t_s), -0.12 + 0.02 * std::sin(w * 0.2 * t_s),
          0.08 + 0.01 * std::sin(w * 0.25 * t_s)};
}

// Soft tissue: a surface 12 cm below each trocar, 250 N/m with 2 N·s/m of
// damping, pushing back along +z (forces of the order the thesis saw, < 3 N).
Eigen::Vector3d tissue_force(const JointVector& q_ve, double depth_rate_m_per_s) {
  const double depth_m = -tip_position(q_ve).z() - 0.12;
  if (depth_m <= 0.0) return Eigen::Vector3d::Zero();
  return {0.0, 0.0, std::max(0.0, 250.0 * depth_m + 2.0 * depth_rate_m_per_s)};
}

struct Summary {
  std::string name;
  std::size_t updates = 0;
  double peak_N = 0.0;
  double p95_N = 0.0;
  double mean_change_N = 0.0;  // mean |displayed − VE| force: what the setting adds or removes
  double max_offset_mm = 0.0;  // largest tip offset shown to the VE (backlash)
  std::size_t faults = 0;
};

Summary run_setting(const NamedSettings& setting, const fs::path& csv_path, double duration_s) {
  Engine engine(setting.engine, {hand(0, 0), hand(1, 0)});
  AtomicOutputFile file(csv_path);
  TrajectoryCsvWriter writer(file.stream());

  std::mt19937_64 rng(2004);  // same VE timing for every setting
  std::uniform_real_distribution<double> rate_Hz(200.0, 2000.0);
  std::array<JointVector, 2> q_ve{hand(0, 0), hand(1, 0)};
  std::array<double, 2> depth{0, 0};
  Summary s;
  s.name = setting.name;
  std::vector<double> magnitudes;
  double t = 0.0, change_sum = 0.0;
  bool first = true;
  while (t < duration_s) {
    const double dt = first ? 0.0 : 1.0 / rate_Hz(rng);
    first = false;
    t += dt;
    for (int i = 0; i < kNumInstruments; ++i) {
      // The VE computes its force from the position it was last shown.
      const double new_depth = -tip_position(q_ve[i]).z();
      const double rate = dt > 0 ? (new_depth - depth[i]) / dt : 0.0;
      depth[i] = new_depth;
      const TrajectoryRow row{t, i, hand(i, t), tissue_force(q_ve[i], rate)};
      const InstrumentOutput out = engine.update(i, {dt, row.position, row.ve_force_N});
      try {
        writer.write(row, out);
      } catch (const TrajectoryCsvError&) {
        file.check();  // the writer's message lacks the path and the cause
        throw;
      }
      q_ve[i] = out.degraded_position;
      const double f = out.displayed_force_N.norm();
      magnitudes.push_back(f);
      change_sum += (out.displayed_force_N - row.ve_force_N).norm();
      s.peak_N = std::max(s.peak_N, f);
      s.max_offset_mm = std::max(s.max_offset_mm, 1e3 * out.tip_offset_m.norm());
      if (out.status & kFaultMask) ++s.faults;
    }
  }
  file.commit();
  s.updates = magnitudes.size();
  std::sort(magnitudes.begin(), magnitudes.end());
  s.p95_N = magnitudes[static_cast<std::size_t>(0.95 * (magnitudes.size() - 1))];
  s.mean_change_N = change_sum / magnitudes.size();
  return s;
}

}  // namespace

void add_engine_demo_command(CLI::App& engine) {
  struct Options {
    std::string out = "engine-demo-output";
    std::string settings_dir;
    double duration_s = 5.0;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = engine.add_subcommand(
      "demo", "Feel one scripted two-handed motion through each of the thesis' settings");
  cmd->add_option("--out", opt->out, "Directory for the per-setting CSV files")
      ->capture_default_str();
  cmd->add_option("--settings-dir", opt->settings_dir,
                  "Directory with the " + std::to_string(std::size(kSettingFiles)) +
                      " settings files the demo reads: " + all_setting_file_names() +
                      " (default: the shipped examples)");
  cmd->add_option("--seconds", opt->duration_s, "Length of the motion")
      ->capture_default_str()
      ->check(number_in(0.1, 600.0));
  cmd->callback([opt] {
    const fs::path dir =
        opt->settings_dir.empty() ? default_settings_dir() : fs::path(opt->settings_dir);
    // Everything that can be refused is, before the first line is printed.
    const std::vector<NamedSettings> settings = load_demo_settings(dir, !opt->settings_dir.empty());
    planning::prepare_plan_folder(opt->out);
    std::printf("HapticLab engine demo: %.1f s of two-handed motion against soft tissue,\n"
                "VE rate wandering 200-2000 Hz, felt through each setting in %s\n\n",
                opt->duration_s, dir.c_str());
    std::printf("%-20s %8s %9s %9s %12s %11s %7s\n", "setting", "updates", "peak N",
                "p95 N", "mean |dF| N", "offset mm", "faults");
    for (std::size_t i = 0; i < settings.size(); ++i) {
      const Summary s = run_setting(settings[i], fs::path(opt->out) / (std::string(kSettingFiles[i]) + ".csv"),
                                    opt->duration_s);
      std::printf("%-20s %8zu %9.3f %9.3f %12.3f %11.2f %7zu\n", s.name.c_str(), s.updates,
                  s.peak_N, s.p95_N, s.mean_change_N, s.max_offset_mm, s.faults);
    }
    std::printf(
        "\nmean |dF|: how far the displayed force is from the VE's on average.\n"
        "offset: largest tip offset the VE was shown (backlash).\n"
        "Per-update CSVs (engine replay format) are in %s/\n",
        opt->out.c_str());
  });
}

}  // namespace hapticlab::app
