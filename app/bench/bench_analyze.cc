#include "app/bench/bench_analyze.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/cli/cli_checks.h"
#include "app/cli/renamed_option.h"
#include "analysis/report/report.h"
#include "analysis/stats/split_mix64.h"
#include "analysis/study/metrics_csv.h"
#include "analysis/study/study_analysis.h"
#include "db/study_db.h"

namespace hapticlab::app {
namespace an = hapticlab::analysis;

namespace {

// CPU seconds of this process and its finished children (gnuplot): the
// figure that does not depend on what else the machine is doing.
double cpu_s() {
  double total = 0.0;
  for (int who : {RUSAGE_SELF, RUSAGE_CHILDREN}) {
    rusage u{};
    ::getrusage(who, &u);
    total += static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
             1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  }
  return total;
}

struct BenchOptions {
  std::string dir;
  std::string db;        // an existing study database instead of the synthetic one
  std::string compare;   // a comparator script (bench/analyze_numpy.py)
  std::string python = "/usr/bin/python3";
  int rounds = 5;
  bool keep = false;
  bool json = false;
  bool no_plots = false;
  double rate_hz = 1000.0;
};

// Runs argv to completion with stdout discarded and stderr into
// `stderr_path`; returns the wall time in seconds. Throws with the command's
// name, exit status and stderr if it fails: a ratio against a failed run
// would mean nothing.
double run_timed(const std::vector<std::string>& argv, const std::filesystem::path& stderr_path) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error("bench analyze: cannot start " + argv[0] + " (fork failed)");
  if (pid == 0) {
    const int null_fd = ::open("/dev/null", O_WRONLY);
    const int err_fd = ::open(stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (null_fd >= 0) ::dup2(null_fd, STDOUT_FILENO);
    if (err_fd >= 0) ::dup2(err_fd, STDERR_FILENO);
    ::execv(args[0], args.data());
    std::fprintf(stderr, "cannot run %s\n", args[0]);
    ::_exit(127);
  }
  int status = 0;
  // Only an interrupted wait is retried: any other error (ECHILD) would
  // spin here for good.
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR)
      throw std::runtime_error("bench analyze: cannot wait for " + argv[0] + ": " + std::strerror(errno));
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::string err;
    if (std::FILE* f = std::fopen(stderr_path.c_str(), "r")) {
      char buf[4096];
      const std::size_t n = std::fread(buf, 1, sizeof buf, f);
      err.assign(buf, n);
      std::fclose(f);
    }
    throw std::runtime_error(argv[0] + (argv.size() > 1 ? " " + argv[1] : std::string()) + " failed (" +
                             (WIFEXITED(status) ? "exit " + std::to_string(WEXITSTATUS(status))
                                                : "signal " + std::to_string(WTERMSIG(status))) +
                             "): " + err);
  }
  return wall_s;
}

// The 1-minute load average (/proc/loadavg), or NaN where there is none:
// the machine is shared, and a ratio means little without it.
double load_average_1min() {
  std::FILE* f = std::fopen("/proc/loadavg", "r");
  double load = std::numeric_limits<double>::quiet_NaN();
  if (f != nullptr) {
    if (std::fscanf(f, "%lf", &load) != 1) load = std::numeric_limits<double>::quiet_NaN();
    std::fclose(f);
  }
  return load;
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// `hapticlab analyze --no-ks --no-plots` and the comparator on the same
// database, as two child processes, alternating so that a busy moment of
// this shared machine hits both alike; the ratio of medians is the result.
void run_compare(const BenchOptions& o, const std::filesystem::path& db_path, const std::filesystem::path& dir,
                 std::size_t instrument_samples) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw std::runtime_error("bench analyze: cannot find this executable (/proc/self/exe)");
  if (!fs::is_regular_file(o.compare)) {
    throw std::runtime_error("--compare is '" + o.compare + "', but no such file exists (expected a script such as "
                             "bench/analyze_numpy.py)");
  }
  const std::vector<std::string> ours = {self.string(), "analyze", "--db", db_path.string(), "--out",
                                         (dir / "compare_out").string(), "--no-ks", "--no-plots"};
  const std::vector<std::string> theirs = {o.python, o.compare, db_path.string()};
  const fs::path err = dir / "compare_stderr.txt";
  std::vector<double> ours_s, theirs_s;
  const double load_before = load_average_1min();
  if (!o.json) std::printf("alternating %d rounds: hapticlab analyze --no-ks --no-plots, then %s\n", o.rounds,
                           o.compare.c_str());
  for (int round = 0; round < o.rounds; ++round) {
    ours_s.push_back(run_timed(ours, err));
    theirs_s.push_back(run_timed(theirs, err));
    if (!o.json) std::printf("  round %d: hapticlab %.3f s, comparator %.3f s\n", round + 1, ours_s.back(),
                             theirs_s.back());
    std::fflush(stdout);
  }
  const double load_after = load_average_1min();
  const double ours_med = median_of(ours_s);
  const double theirs_med = median_of(theirs_s);
  const double ratio = theirs_med / ours_med;
  const auto [ours_min, ours_max] = std::minmax_element(ours_s.begin(), ours_s.end());
  const auto [theirs_min, theirs_max] = std::minmax_element(theirs_s.begin(), theirs_s.end());
  if (o.json) {
    std::printf("{\"instrument_samples\": %zu, \"rounds\": %d, \"hapticlab_median_s\": %.4f, "
                "\"hapticlab_min_s\": %.4f, \"hapticlab_max_s\": %.4f, \"comparator_median_s\": %.4f, "
                "\"comparator_min_s\": %.4f, \"comparator_max_s\": %.4f, \"speedup\": %.3f, "
                "\"load_average_before\": %s, \"load_average_after\": %s, \"target_speedup\": 5}\n",
                instrument_samples, o.rounds, ours_med, *ours_min, *ours_max, theirs_med, *theirs_min, *theirs_max,
                ratio, json_number(load_before).c_str(), json_number(load_after).c_str());
  } else {
    std::printf("median (range): hapticlab %.3f s (%.3f-%.3f), comparator %.3f s (%.3f-%.3f): hapticlab is %.2fx "
                "faster (target >= 5x quiet, >= 3x busy); load average %.2f before, %.2f after\n",
                ours_med, *ours_min, *ours_max, theirs_med, *theirs_min, *theirs_max, ratio, load_before, load_after);
  }
}

double uniform(an::SplitMix64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng.next() >> 11) * 0x1.0p-53;
}

// One hand's trial as the simulated rig would log it: a smooth 3-D tip
// motion (three sinusoids per axis, velocity their derivative), tissue
// contacts of 0.2–2 s separated by 0.1–1 s gaps, each a half-sine force
// pulse of a trial-specific peak, and the insertion/contact events.
struct HandPlan {
  double insertion_s = 0.0;  // when the tool passes 20 mm
  std::vector<std::pair<double, double>> contacts;
  std::vector<double> contact_shape;  // exponent of each contact's sin^k pulse
  double force_peak_N = 0.0;
  std::array<std::array<double, 3>, 3> amplitude_m{};
  std::array<std::array<double, 3>, 3> omega_rad_per_s{};
  std::array<std::array<double, 3>, 3> phase_rad{};
};

HandPlan plan_hand(an::SplitMix64& rng, double duration_s, double force_peak_N) {
  HandPlan h;
  h.insertion_s = uniform(rng, 0.8, 2.0);
  h.force_peak_N = force_peak_N;
  for (std::size_t axis = 0; axis < 3; ++axis) {
    for (std::size_t k = 0; k < 3; ++k) {
      h.amplitude_m[axis][k] = uniform(rng, 0.002, 0.012);
      h.omega_rad_per_s[axis][k] = 2 * std::numbers::pi * uniform(rng, 0.05, 1.2);
      h.phase_rad[axis][k] = uniform(rng, 0, 2 * std::numbers::pi);
    }
  }
  double t = h.insertion_s + uniform(rng, 0.5, 3.0);
  while (t < duration_s - 3.0) {
    const double length = uniform(rng, 0.2, 2.0);
    h.contacts.emplace_back(t, std::min(t + length, duration_s - 2.0));
    h.contact_shape.push_back(uniform(rng, 0.5, 3.0));
    t += length + uniform(rng, 0.1, 1.0);
  }
  return h;
}

void log_hand(db::StudyDb& db, std::int64_t trial, int hand, const HandPlan& h, double duration_s, double rate_hz,
              an::SplitMix64& rng) {
  const double dt_s = 1.0 / rate_hz;
  const auto n = static_cast<std::size_t>(duration_s * rate_hz);
  constexpr std::size_t kChunk = 4096;  // about what the SampleWriter batches at 1 kHz
  std::vector<db::StoredSample> chunk;
  chunk.reserve(kChunk);
  std::size_t contact = 0;
  double t = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    db::StoredSample s;
    s.tick = i;
    s.t_s = t;
    s.dt_s = dt_s;
    for (std::size_t axis = 0; axis < 3; ++axis) {
      double p = 0.0;
      double v = 0.0;
      for (std::size_t k = 0; k < 3; ++k) {
        const double w = h.omega_rad_per_s[axis][k];
        p += h.amplitude_m[axis][k] * std::sin(w * t + h.phase_rad[axis][k]);
        v += h.amplitude_m[axis][k] * w * std::cos(w * t + h.phase_rad[axis][k]);
      }
      s.value.tip_position_m[axis] = p + 2e-6 * uniform(rng, -1, 1);  // encoder-like jitter
      s.value.tip_velocity_m_per_s[axis] = v;
    }
    while (contact < h.contacts.size() && t > h.contacts[contact].second) ++contact;
    if (contact < h.contacts.size() && t >= h.contacts[contact].first) {
      const auto [a, b] = h.contacts[contact];
      const double f = h.force_peak_N * std::pow(std::sin(std::numbers::pi * (t - a) / (b - a)), h.contact_shape[contact]);
      s.value.ve_force_N = {0.3 * f, -0.2 * f, 0.93 * f};
      s.value.displayed_force_N = s.value.ve_force_N;
      s.value.in_contact = true;
    }
    s.value.raw_position[0] = std::min(0.04, 0.02 * t / h.insertion_s);
    s.value.degraded_position[0] = s.value.raw_position[0];
    chunk.push_back(s);
    if (chunk.size() == kChunk || i + 1 == n) {
      db.insert_chunk(trial, hand, chunk);
      chunk.clear();
    }
    t += dt_s;
  }
  auto event = [&](double time_s, const char* type) {
    db.add_event({trial, time_s, type, hand, 0, {}});
  };
  event(h.insertion_s, "insertion_passed_20mm");
  for (const auto& [a, b] : h.contacts) {
    event(a, "contact_start");
    event(b, "contact_end");
  }
}

// The thesis' study as run (Table 3.3; examples/protocols/thesis_as_run.json):
// S1 and S2 did both tasks, S3 only dissection, 5 settings each, 3
// dissection and 9 clip repetitions: 135 trials. Dissection trials last
// 90–120 s, clip trials 60–90 s.
std::size_t build_study(const std::filesystem::path& path, double rate_hz, std::size_t& samples) {
  db::StudyDb db(path);
  const std::int64_t study = db.add_study({"bench: thesis as run", "{}", 2004, "bench"});
  const std::vector<std::string> names = {"High Fidelity", "No Force Feedback", "All Degradations",
                                          "Inertia + Backlash", "Cogging", "Friction",
                                          "Inertia", "Force Saturation"};
  std::vector<std::int64_t> setting_ids;
  for (const auto& n : names) setting_ids.push_back(db.add_setting_json(study, n, "{}"));
  const std::vector<std::vector<int>> assigned = {{0, 1, 2, 4, 6}, {0, 1, 2, 4, 5}, {0, 1, 2, 3, 7}};
  an::SplitMix64 rng(2004);
  std::size_t trials = 0;
  for (std::size_t p = 0; p < 3; ++p) {
    const std::int64_t pid = db.add_participant(study, "S" + std::to_string(p + 1));
    const std::int64_t session = db.begin_session(pid, "sim", "virtual", 1000.0);
    const double participant_force = 0.6 + 0.3 * static_cast<double>(p);
    int position = 0;
    for (const char* task : {"dissection", "clip"}) {
      if (p == 2 && std::string(task) == "clip") continue;
      const int reps = std::string(task) == "clip" ? 9 : 3;
      for (int rep = 1; rep <= reps; ++rep) {
        for (std::size_t k = 0; k < assigned[p].size(); ++k) {
          // Rotate the order each repetition, as a block-randomized schedule would.
          const int setting = assigned[p][(k + static_cast<std::size_t>(rep)) % assigned[p].size()];
          const std::int64_t trial =
              db.add_trial({pid, task, setting_ids[static_cast<std::size_t>(setting)], rep, rep, ++position});
          db.start_trial(trial, session);
          const double duration_s =
              std::string(task) == "clip" ? uniform(rng, 60.0, 90.0) : uniform(rng, 90.0, 120.0);
          const double setting_force = setting == 1 ? 1.8 : setting == 7 ? 0.9 : 1.0;
          db::Transaction tx(db.connection());
          for (int hand = 0; hand < 2; ++hand) {
            const HandPlan h = plan_hand(rng, duration_s,
                                         participant_force * setting_force * uniform(rng, 0.8, 1.25) *
                                             (hand == 1 ? 1.0 : 0.7));
            log_hand(db, trial, hand, h, duration_s, rate_hz, rng);
            samples += static_cast<std::size_t>(duration_s * rate_hz);
          }
          tx.commit();
          db.end_trial(trial, db::TrialStatus::kComplete);
          ++trials;
        }
      }
    }
    db.end_session(session);
  }
  return trials;
}

// The bench's study: built in the folder (not timed), or the --db given.
struct AnalyzeBenchStudy {
  std::filesystem::path dir, db_path;
  std::size_t samples = 0;
  std::size_t trials = 0;
  double build_s = 0.0;
};

AnalyzeBenchStudy analyze_bench_study(const BenchOptions& o) {
  namespace fs = std::filesystem;
  AnalyzeBenchStudy s;
  s.dir = o.dir.empty() ? fs::temp_directory_path() / ("hapticlab_bench_analyze_" + std::to_string(::getpid()))
                        : fs::path(o.dir);
  fs::create_directories(s.dir);
  s.db_path = o.db.empty() ? s.dir / "study.db" : fs::path(o.db);
  if (o.db.empty()) {
    fs::remove(s.db_path);
    if (!o.json) std::printf("building a thesis-sized study in %s (not timed) ...\n", s.db_path.c_str());
    std::fflush(stdout);
    const auto b0 = std::chrono::steady_clock::now();
    s.trials = build_study(s.db_path, o.rate_hz, s.samples);
    s.build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - b0).count();
  } else if (!fs::is_regular_file(s.db_path)) {
    throw std::runtime_error("--db is '" + o.db + "', but no such file exists (expected a study database)");
  }
  return s;
}

// What the bench made is removed unless --keep (a --db given is never removed).
void remove_analyze_bench_files(const BenchOptions& o, const AnalyzeBenchStudy& s) {
  std::error_code ignored;
  if (o.dir.empty()) std::filesystem::remove_all(s.dir, ignored);
  else if (o.db.empty()) std::filesystem::remove(s.db_path, ignored);
}

void print_analyze_bench(const BenchOptions& o, const AnalyzeBenchStudy& s, double db_mb, double analysis_s,
                         double report_s, double cpu_used_s, std::size_t figures) {
  if (o.json) {
    std::printf("{\"trials\": %zu, \"instrument_samples\": %zu, \"db_MB\": %.1f, \"build_s\": %.2f, "
                "\"analysis_s\": %.3f, \"report_s\": %.3f, \"total_s\": %.3f, \"cpu_s\": %.3f, "
                "\"figures\": %zu, \"target_s\": 10}\n",
                s.trials, s.samples, db_mb, s.build_s, analysis_s, report_s, analysis_s + report_s, cpu_used_s,
                figures);
  } else {
    std::printf("study: %zu trials, %zu instrument-samples (%.0f Hz), %.1f MB database, built in %.1f s\n", s.trials,
                s.samples, o.rate_hz, db_mb, s.build_s);
    std::printf("analysis (read, metrics, statistics, KS bootstrap): %.3f s\n", analysis_s);
    std::printf("metrics CSV + report (%zu figures):                   %.3f s\n", figures, report_s);
    std::printf("total: %.3f s wall, %.3f s CPU incl. gnuplot (target: under 10 s)\n", analysis_s + report_s,
                cpu_used_s);
  }
}

void run_bench(const BenchOptions& o) {
  namespace fs = std::filesystem;
  AnalyzeBenchStudy s = analyze_bench_study(o);
  if (!o.compare.empty()) {
    run_compare(o, s.db_path, s.dir, s.samples);
    if (!o.keep) remove_analyze_bench_files(o, s);
    return;
  }

  // Timed: exactly what `hapticlab analyze` does.
  const double cpu0_s = cpu_s();
  const auto t0 = std::chrono::steady_clock::now();
  const an::StudyAnalysis analysis = an::analyze_study_file(s.db_path, {});
  const auto t1 = std::chrono::steady_clock::now();
  an::ReportOptions report;
  report.plots = !o.no_plots;
  fs::create_directories(s.dir / "out");
  an::write_metrics_csv(analysis, s.dir / "out" / "metrics.csv");
  const an::ReportFiles files = an::write_report(analysis, s.dir / "out", report);
  const auto t2 = std::chrono::steady_clock::now();
  const double cpu_used_s = cpu_s() - cpu0_s;
  const double analysis_s = std::chrono::duration<double>(t1 - t0).count();
  const double report_s = std::chrono::duration<double>(t2 - t1).count();
  const double db_mb = static_cast<double>(fs::file_size(s.db_path)) / 1e6;
  if (s.trials == 0) {
    s.trials = analysis.trials.size();
  }
  print_analyze_bench(o, s, db_mb, analysis_s, report_s, cpu_used_s, files.figures.size());
  if (!o.keep) {
    remove_analyze_bench_files(o, s);
  } else if (!o.json) {
    std::printf("kept %s and the report in %s\n", s.db_path.c_str(), (s.dir / "out").c_str());
  }
}

}  // namespace

void add_bench_analyze_command(CLI::App& bench) {
  auto opt = std::make_shared<BenchOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "analyze",
      "Time `hapticlab analyze` on a synthetic thesis-sized study (3 participants, 2 tasks, 135 trials "
      "of 1-2 minutes at 1 kHz, both hands), built first and not timed; target under 10 s");
  CLI::Option* out = cmd->add_option(
      "--out", opt->dir, "Directory for the synthetic database and report (default: a temporary one, removed after)");
  add_old_spelling(*cmd, out, "--dir", opt->dir);
  cmd->add_flag("--keep", opt->keep, "Keep the database and report (in --out, or the temporary directory)");
  cmd->add_option("--rate-hz", opt->rate_hz, "Logging rate of the synthetic trials, Hz (> 0)")->capture_default_str()
      ->check(positive_number());
  cmd->add_flag("--no-plots", opt->no_plots, "Time the report without figures (gnuplot not needed)");
  cmd->add_option("--db", opt->db,
                  "Time this study database (e.g. the demo's demo-output/study.db) instead of a synthetic one")
      ->check(CLI::ExistingFile);
  cmd->add_option("--compare", opt->compare,
                  "Run this comparator script (bench/analyze_numpy.py) and `hapticlab analyze --no-ks --no-plots` "
                  "on the same database, alternating, and print the ratio of their median wall times")
      ->check(CLI::ExistingFile);
  cmd->add_option("--rounds", opt->rounds, "Rounds of each with --compare (1..100)")->capture_default_str()
      ->check(whole_number_in(1, 100));
  cmd->add_option("--python", opt->python, "Python 3 with numpy, zstandard and crc32c, for --compare")->capture_default_str();
  cmd->add_flag("--json", opt->json, "Print one JSON object instead of text");
  cmd->callback([opt] { run_bench(*opt); });
}

}  // namespace hapticlab::app
