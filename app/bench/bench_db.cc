#include "app/bench/bench_db.h"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/cli/cli_checks.h"
#include "app/cli/renamed_option.h"
#include "app/cli/data_paths.h"
#include "core/settings/settings_json.h"
#include "core/sim/trial_runner.h"
#include "db/sample_writer.h"
#include "db/study_db.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct BenchDbOptions {
  double rate_seconds = 5.0;   // (a) wall time of the flood
  double size_seconds = 60.0;  // (b) simulated seconds logged, scaled to an hour
  double loop_seconds = 5.0;   // (c) wall time per loop run (off, then on)
  std::string dir;             // where the scratch databases go
  bool json = false;
};

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

EngineSettings all_degradations() {
  return load_settings_file(default_settings_dir() / "all_degradations.json").engine;
}

// A scratch folder for the benchmark's databases, removed afterwards.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& parent) {
    const fs::path base = parent.empty() ? fs::temp_directory_path() : fs::path(parent);
    path_ = base / ("hapticlab_bench_db_" + std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  fs::path file(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

// A fresh database holding one running trial; returns its id.
std::int64_t new_running_trial(const fs::path& path) {
  fs::remove(path);
  db::StudyDb db(path);
  const std::int64_t study = db.add_study({"bench", "{}", 1, "bench"});
  const std::int64_t participant = db.add_participant(study, "B01");
  const std::int64_t setting = db.add_setting_json(study, "All Degradations", "{}");
  const std::int64_t trial = db.add_trial({participant, "dissection", setting, 1, 1, 1});
  db.start_trial(trial, db.begin_session(participant, "sim", "virtual", 1000.0));
  return trial;
}

// Realistic samples: the simulated participant doing the dissection task
// through all degradations, virtual clock, 1 kHz.
std::vector<LoopSample> record_sim(double simulated_s) {
  SimTrialConfig c;
  c.task = TaskKind::kDissection;
  c.settings = all_degradations();
  c.max_duration_s = simulated_s;
  c.stop_when_complete = false;
  std::vector<LoopSample> out;
  out.reserve(static_cast<std::size_t>(simulated_s * 1000.0) + 16);
  SimTrialSink sink;
  sink.on_sample = [&](const LoopSample& s) { out.push_back(s); };
  run_sim_trial(c, sink);
  return out;
}

// ---- (a) sustained rate: a producer thread refills the queue as fast as
// the writer empties it, cycling through recorded samples with rising
// ticks; times are a running sum as the virtual clock produces them.
struct RateResult {
  double wall_s = 0.0;
  std::uint64_t updates = 0;
  std::uint64_t commits = 0;
  double instrument_samples_per_s = 0.0;
  double writer_cpu_s = 0.0;
  double per_writer_cpu_s = 0.0;  // instrument-samples per CPU-second of the writer thread
};

RateResult bench_rate(const std::vector<LoopSample>& source, const fs::path& path, double seconds) {
  const std::int64_t trial = new_running_trial(path);
  SpscQueue<LoopSample> samples(1 << 16);
  SpscQueue<TaskEvent> events(1 << 10);
  std::atomic<bool> stop{false};
  const Clock::time_point t0 = Clock::now();
  db::SampleWriter writer(path, trial, samples, events);
  std::thread producer([&] {
    double t_s = 0.0;
    for (std::uint64_t tick = 0; !stop.load(std::memory_order_relaxed); ++tick) {
      LoopSample s = source[tick % source.size()];
      s.tick = tick;
      t_s += s.dt_s;
      s.t_s = t_s;
      // Full: the writer is the bottleneck, which is what is measured.
      // Sleep rather than spin, so the producer does not take the writer's
      // core on a small machine (the queue holds 65 ms at 1M updates/s).
      while (!samples.try_push(s)) {
        if (stop.load(std::memory_order_relaxed)) return;
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
    }
  });
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  stop = true;
  producer.join();
  writer.finish({});  // drains what is left: every pushed update is counted and timed
  RateResult r;
  r.wall_s = seconds_since(t0);
  r.updates = writer.stats().updates;
  r.commits = writer.stats().commits;
  r.instrument_samples_per_s = 2.0 * static_cast<double>(r.updates) / r.wall_s;
  r.writer_cpu_s = writer.stats().thread_cpu_s;
  if (r.writer_cpu_s > 0.0) r.per_writer_cpu_s = 2.0 * static_cast<double>(r.updates) / r.writer_cpu_s;
  return r;
}

// ---- (b) size: log the recorded samples once, checkpoint, and compare the
// file with the same database before any sample. `wall_timing`: t_s and dt
// as the wall clock gives them (every period a little different, t_s not a
// running sum), which is what real sessions store.
struct SizeResult {
  std::uint64_t updates = 0;
  double simulated_s = 0.0;
  std::uintmax_t bytes = 0;
  double bytes_per_hour = 0.0;
};

std::uintmax_t checkpointed_size(const fs::path& path) {
  {
    db::StudyDb db(path, {db::OpenOptions::Integrity::kSkip, /*recover=*/false});
    db.connection().exec("PRAGMA wal_checkpoint(TRUNCATE)");
  }
  return fs::file_size(path);
}

SizeResult bench_size(std::vector<LoopSample> source, const fs::path& path, bool wall_timing) {
  if (wall_timing) {
    // ±20 µs of scheduling jitter, deterministic (a 64-bit LCG), on a clock
    // that counts nanoseconds, with the loop's own arithmetic
    // (core/common/clock.h WallClock::now_s, core/loop/haptic_loop.cc):
    // now_s = ns / 1e9 since the clock's start, t_s = now_s - t0_s,
    // dt_s = now_s - the previous update's now_s.
    std::uint64_t state = 12345;
    const auto now_s = [](std::int64_t ns) { return std::chrono::duration<double>(std::chrono::nanoseconds(ns)).count(); };
    const std::int64_t t0_ns = 137'000;  // the clock started a little before the loop
    double last_now_s = now_s(t0_ns);
    for (std::size_t i = 0; i < source.size(); ++i) {
      state = state * 6364136223846793005ull + 1442695040888963407ull;
      const auto jitter_ns = static_cast<std::int64_t>(state >> 33) % 40'001 - 20'000;
      const double now = now_s(t0_ns + static_cast<std::int64_t>(i) * 1'000'000 + (i == 0 ? 0 : jitter_ns));
      source[i].dt_s = i == 0 ? 1e-3 : now - last_now_s;  // the loop's first dt is the nominal period
      source[i].t_s = now - now_s(t0_ns);
      last_now_s = now;
    }
  }
  const std::int64_t trial = new_running_trial(path);
  const std::uintmax_t empty = checkpointed_size(path);
  {
    SpscQueue<LoopSample> samples(1 << 14);
    SpscQueue<TaskEvent> events(1 << 6);
    db::SampleWriter writer(path, trial, samples, events);
    for (const LoopSample& s : source)
      while (!samples.try_push(s)) std::this_thread::yield();
    writer.finish({});
  }
  SizeResult r;
  r.updates = source.size();
  r.simulated_s = source.back().t_s - source.front().t_s;
  r.bytes = checkpointed_size(path) - empty;
  r.bytes_per_hour = static_cast<double>(r.bytes) * 3600.0 / r.simulated_s;
  return r;
}

// ---- (c) the wall-clock loop at 1 kHz with the full simulated rig; samples
// drained and discarded (logging off) or written by the SampleWriter
// (logging on).
struct LoopResult {
  LoopTimingSummary timing;
  std::uint64_t dropped_samples = 0;
  std::uint64_t logged = 0;
};

LoopResult bench_loop(double seconds, bool logging, const fs::path& path) {
  SimTrialConfig c;
  c.task = TaskKind::kDissection;
  c.settings = all_degradations();
  c.clock = ClockKind::kWall;
  c.rate_Hz = 1000.0;
  c.max_duration_s = seconds;
  c.stop_when_complete = false;
  SimRig rig(c);
  HapticLoop& loop = rig.loop();
  LoopResult r;
  std::unique_ptr<db::SampleWriter> writer;
  if (logging) writer = std::make_unique<db::SampleWriter>(path, new_running_trial(path), loop.samples(), loop.events());
  if (!loop.start()) throw std::runtime_error("bench db: the simulated device refused to start");
  std::vector<LoopSample> sink(256);
  while (loop.running()) {
    if (!logging) {
      // The same consumer as `bench loop`: pop and discard.
      TaskEvent e;
      while (loop.samples().pop_bulk(sink.data(), sink.size()) > 0) {
      }
      while (loop.events().try_pop(e)) {
      }
    }
    std::this_thread::sleep_for(std::chrono::microseconds(logging ? 10'000 : 200));
  }
  loop.join();
  r.timing = loop.timing();
  r.dropped_samples = loop.dropped_samples();
  if (writer) {
    db::TrialOutcome outcome;
    outcome.timing = r.timing;
    outcome.dropped_samples = r.dropped_samples;
    outcome.dropped_events = loop.dropped_events();
    writer->finish(outcome);
    r.logged = writer->stats().updates;
  }
  return r;
}

nlohmann::json bench_db_loop_json(const LoopResult& r) {
  return nlohmann::json{{"updates", r.timing.count},
                        {"p50_period_us", r.timing.p50_period_s * 1e6},
                        {"p99_period_us", r.timing.p99_period_s * 1e6},
                        {"max_period_us", r.timing.max_period_s * 1e6},
                        {"overruns", r.timing.overruns},
                        {"dropped_samples", r.dropped_samples},
                        {"logged_updates", r.logged}};
}

void print_bench_db_json(const BenchDbOptions& opt, const RateResult& rate, const SizeResult& wall,
                         const SizeResult& virt, const LoopResult& off, const LoopResult& on) {
  const nlohmann::json j = {
      {"benchmark", "db"},
      {"rate", {{"instrument_samples_per_s", rate.instrument_samples_per_s}, {"updates", rate.updates},
                {"wall_s", rate.wall_s}, {"commits", rate.commits}, {"writer_cpu_s", rate.writer_cpu_s},
                {"instrument_samples_per_writer_cpu_s", rate.per_writer_cpu_s}}},
      {"size", {{"simulated_s", wall.simulated_s}, {"wall_clock_bytes_per_hour", wall.bytes_per_hour},
                {"virtual_clock_bytes_per_hour", virt.bytes_per_hour}}},
      {"loop_1kHz", {{"seconds", opt.loop_seconds}, {"logging_off", bench_db_loop_json(off)},
                     {"logging_on", bench_db_loop_json(on)}}}};
  std::printf("%s\n", j.dump(2).c_str());
}

void print_bench_db_loop(const BenchDbOptions& opt, const LoopResult& off, const LoopResult& on) {
  std::printf("(c) wall-clock loop, 1 kHz, full simulated rig, %.1f s each:\n", opt.loop_seconds);
  for (const auto& [name, r] : {std::pair{"logging off", &off}, std::pair{"logging on ", &on}})
    std::printf("    %s: period p50 %.1f us, p99 %.1f us, max %.1f us, overruns %llu, dropped samples %llu\n",
                name, r->timing.p50_period_s * 1e6, r->timing.p99_period_s * 1e6, r->timing.max_period_s * 1e6,
                static_cast<unsigned long long>(r->timing.overruns),
                static_cast<unsigned long long>(r->dropped_samples));
  std::printf("    p99 difference (on - off): %+.1f us; %llu updates logged\n",
              (on.timing.p99_period_s - off.timing.p99_period_s) * 1e6, static_cast<unsigned long long>(on.logged));
}

void run_bench_db(const BenchDbOptions& opt) {
  ScratchDir dir(opt.dir);
  if (!opt.json)
    std::printf("hapticlab bench db: SampleWriter into SQLite (WAL, synchronous=NORMAL, commit every 50 ms, "
                "1000-update chunks); scratch files in %s\n",
                dir.file("").string().c_str());

  const Clock::time_point t_rec = Clock::now();
  const std::vector<LoopSample> recorded = record_sim(opt.size_seconds);
  const double record_s = seconds_since(t_rec);

  const RateResult rate = bench_rate(recorded, dir.file("rate.db"), opt.rate_seconds);
  if (!opt.json)
    std::printf("(a) sustained logging rate: %.2f million instrument-samples/s (%llu updates x 2 instruments in "
                "%.2f s, %llu commits); target >= 1 million/s: %s\n"
                "    writer thread CPU %.2f s: %.2f million instrument-samples per CPU-second\n",
                rate.instrument_samples_per_s / 1e6, static_cast<unsigned long long>(rate.updates), rate.wall_s,
                static_cast<unsigned long long>(rate.commits),
                rate.instrument_samples_per_s >= 1e6 ? "met" : "NOT met", rate.writer_cpu_s,
                rate.per_writer_cpu_s / 1e6);

  const SizeResult wall = bench_size(recorded, dir.file("size_wall.db"), true);
  const SizeResult virt = bench_size(recorded, dir.file("size_virtual.db"), false);
  if (!opt.json) {
    std::printf("(b) database size, 2 instruments at 1 kHz, %.0f s of simulated dissection (recorded in %.1f s):\n",
                wall.simulated_s, record_s);
    std::printf("    wall-clock timing:   %.1f MB per hour (%.1f bytes per instrument-sample)\n",
                wall.bytes_per_hour / 1e6, static_cast<double>(wall.bytes) / (2.0 * static_cast<double>(wall.updates)));
    std::printf("    virtual-clock timing: %.1f MB per hour (%.1f bytes per instrument-sample)\n",
                virt.bytes_per_hour / 1e6, static_cast<double>(virt.bytes) / (2.0 * static_cast<double>(virt.updates)));
  }

  const LoopResult off = bench_loop(opt.loop_seconds, false, dir.file("loop.db"));
  const LoopResult on = bench_loop(opt.loop_seconds, true, dir.file("loop.db"));
  if (opt.json)
    print_bench_db_json(opt, rate, wall, virt, off, on);
  else
    print_bench_db_loop(opt, off, on);
}

}  // namespace

void add_bench_db_command(CLI::App& bench) {
  auto opt = std::make_shared<BenchDbOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "db", "Study database: sustained logging rate, bytes per hour at 1 kHz, and the 1 kHz loop's period "
            "with logging off and on");
  cmd->add_option("--rate-seconds", opt->rate_seconds, "Wall time of the logging-rate flood [s]")
      ->check(number_in(0.5, 600.0))
      ->capture_default_str();
  cmd->add_option("--size-seconds", opt->size_seconds,
                  "Simulated seconds of 1 kHz logging measured for the size, scaled to an hour [s]")
      ->check(number_in(1.0, 3600.0))
      ->capture_default_str();
  cmd->add_option("--loop-seconds", opt->loop_seconds, "Wall time of each 1 kHz loop run, off then on [s]")
      ->check(number_in(0.5, 3600.0))
      ->capture_default_str();
  CLI::Option* scratch =
      cmd->add_option("--scratch-dir", opt->dir, "Folder for the scratch databases (default: the system temp folder)");
  add_old_spelling(*cmd, scratch, "--dir", opt->dir);
  cmd->add_flag("--json", opt->json, "Machine-readable output");
  cmd->callback([opt] { run_bench_db(*opt); });
}

}  // namespace hapticlab::app
