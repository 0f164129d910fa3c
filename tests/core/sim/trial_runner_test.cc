// A whole simulated trial: sim device held by a simulated participant,
// degradation engine, task VE and haptic loop on the virtual clock.
//
// - the same seeds give the same samples, bit for bit; other seeds do not;
// - both tasks complete under every one of the thesis' eight settings;
// - a device fault in the middle of a trial stops the forces and is reported;
// - the thesis' qualitative findings (3.4): No Force Feedback raises the
//   right hand's 95th-percentile tissue force markedly over High Fidelity,
//   the mildest degradations change it little. Thresholds sit well below
//   the margins measured (numbers in each test), so tuning the participant
//   does not trip them unless the finding itself goes.
#include "core/sim/trial_runner.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/device/workstation_spec.h"
#include "core/settings/settings_json.h"
#include "testing/fitted_point.h"

namespace hapticlab {
namespace {

// The thesis' eight study settings (Table 3.1), as shipped.
const char* const kThesisSettings[] = {"high_fidelity", "no_force_feedback", "inertia",
                                       "inertia_backlash", "friction",         "cogging",
                                       "force_saturation", "all_degradations"};

EngineSettings shipped(const std::string& name) {
  return load_settings_file(std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/" + name + ".json")
      .engine;
}

// The thesis' contact threshold: |F| below 1 mN is not touching (3.3.5.2).
constexpr double kMinContactForce_N = 1e-3;

double magnitude(const Vec3& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

// Nearest-rank 95th percentile of |VE force| over the samples in contact.
double p95_contact_force_N(std::vector<double> forces) {
  if (forces.empty()) return 0.0;
  std::sort(forces.begin(), forces.end());
  const auto rank = static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(forces.size())));
  return forces[rank - 1];
}

struct Recorded {
  SimTrialResult result;
  std::vector<LoopSample> samples;
  std::vector<TaskEvent> events;
};

Recorded record(const SimTrialConfig& config) {
  Recorded r;
  SimTrialSink sink;
  sink.on_sample = [&](const LoopSample& s) { r.samples.push_back(s); };
  sink.on_event = [&](const TaskEvent& e) { r.events.push_back(e); };
  r.result = run_sim_trial(config, sink);
  return r;
}

struct ForceSummary {
  SimTrialResult result;
  std::array<double, 2> p95_N{0.0, 0.0};  // per instrument
};

ForceSummary run_for_forces(const SimTrialConfig& config) {
  std::array<std::vector<double>, 2> forces;
  SimTrialSink sink;
  sink.on_sample = [&](const LoopSample& s) {
    for (std::size_t i = 0; i < 2; ++i) {
      const double f = magnitude(s.instrument[i].ve_force_N);
      if (f >= kMinContactForce_N) forces[i].push_back(f);
    }
  };
  ForceSummary out;
  out.result = run_sim_trial(config, sink);
  for (std::size_t i = 0; i < 2; ++i) out.p95_N[i] = p95_contact_force_N(std::move(forces[i]));
  return out;
}

// Bitwise: doubles compared by their bytes (so −0 ≠ 0 and NaN == same NaN).
template <typename T>
bool same_bytes(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

bool same_sample(const LoopSample& a, const LoopSample& b) {
  if (a.tick != b.tick || !same_bytes(a.t_s, b.t_s) || !same_bytes(a.dt_s, b.dt_s) ||
      a.device_status != b.device_status)
    return false;
  for (std::size_t i = 0; i < 2; ++i) {
    const InstrumentSample& x = a.instrument[i];
    const InstrumentSample& y = b.instrument[i];
    if (!same_bytes(x.raw_position, y.raw_position) || !same_bytes(x.degraded_position, y.degraded_position) ||
        !same_bytes(x.tip_position_m, y.tip_position_m) ||
        !same_bytes(x.tip_velocity_m_per_s, y.tip_velocity_m_per_s) ||
        !same_bytes(x.ve_force_N, y.ve_force_N) || !same_bytes(x.displayed_force_N, y.displayed_force_N) ||
        !same_bytes(x.joint_force, y.joint_force) || x.engine_status != y.engine_status ||
        x.in_contact != y.in_contact)
      return false;
  }
  return true;
}

bool same_event(const TaskEvent& a, const TaskEvent& b) {
  return same_bytes(a.t_s, b.t_s) && a.type == b.type && a.instrument == b.instrument && a.index == b.index;
}

// Index of the first sample that differs, or -1 if the streams are identical.
long first_difference(const Recorded& a, const Recorded& b) {
  const std::size_t n = std::min(a.samples.size(), b.samples.size());
  for (std::size_t k = 0; k < n; ++k)
    if (!same_sample(a.samples[k], b.samples[k])) return static_cast<long>(k);
  return a.samples.size() == b.samples.size() ? -1 : static_cast<long>(n);
}

SimTrialConfig trial(TaskKind task, const std::string& setting, std::uint64_t person,
                     std::uint64_t trial_seed) {
  SimTrialConfig c;
  c.task = task;
  c.settings = shipped(setting);
  c.participant_seed = person;
  c.trial_seed = trial_seed;
  c.practice_trials = 10;  // trained, as the thesis' surgeons were before recording
  c.max_duration_s = 180.0;
  return c;
}

// --- determinism

TEST(TrialRunnerTest, SameSeedsGiveBitIdenticalSamplesAndEvents) {
  SimTrialConfig fixed = trial(TaskKind::kDissection, "all_degradations", 3, 11);
  SimTrialConfig wander = trial(TaskKind::kClip, "inertia_backlash", 4, 12);
  wander.thesis_rate = true;  // the VE rate wandering 200..2000 Hz, seeded too
  for (const SimTrialConfig& c : {fixed, wander}) {
    const Recorded a = record(c);
    const Recorded b = record(c);
    ASSERT_TRUE(a.result.task_complete);
    ASSERT_GT(a.samples.size(), 5000u);
    EXPECT_EQ(a.result.dropped_samples, 0u);
    EXPECT_EQ(a.samples.size(), a.result.samples);
    EXPECT_EQ(first_difference(a, b), -1) << to_string(c.task);
    ASSERT_EQ(a.events.size(), b.events.size());
    for (std::size_t k = 0; k < a.events.size(); ++k) EXPECT_TRUE(same_event(a.events[k], b.events[k])) << k;
    EXPECT_TRUE(same_bytes(a.result.duration_s, b.result.duration_s));
    for (std::size_t k = 0; k < a.samples.size(); ++k) ASSERT_EQ(a.samples[k].tick, k);
  }
  // The wandering rate really wanders: periods between 1/2000 and 1/200 s.
  const Recorded w = record(wander);
  double dt_min = 1.0, dt_max = 0.0;
  for (std::size_t k = 1; k < w.samples.size(); ++k) {
    dt_min = std::min(dt_min, w.samples[k].dt_s);
    dt_max = std::max(dt_max, w.samples[k].dt_s);
  }
  EXPECT_GE(dt_min, 1.0 / 2000.0 - 1e-12);
  EXPECT_LE(dt_max, 1.0 / 200.0 + 1e-12);
  EXPECT_GT(dt_max / dt_min, 3.0);
}

TEST(TrialRunnerTest, AnotherParticipantOrTrialSeedGivesAnotherTrial) {
  const SimTrialConfig base = trial(TaskKind::kDissection, "high_fidelity", 1, 1);
  SimTrialConfig person = base;
  person.participant_seed = 2;
  SimTrialConfig other_trial = base;
  other_trial.trial_seed = 2;
  const Recorded a = record(base);
  for (const SimTrialConfig& c : {person, other_trial}) {
    const Recorded b = record(c);
    ASSERT_TRUE(b.result.task_complete);
    const long diff = first_difference(a, b);
    EXPECT_NE(diff, -1);
    // Not just a different ending: the motions part within the first second.
    EXPECT_GE(diff, 0);
    EXPECT_LT(diff, 1000);
  }
}

TEST(TrialRunnerTest, TheSimulationIsBlindToTheSettingsName) {
  // The same physics under two names (and descriptions), loaded the way a
  // study loads its settings files: every sample and event is identical,
  // byte for byte. A participant model that read the name (or anything but
  // the physics) would part the two runs.
  const std::string path = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/all_degradations.json";
  const NamedSettings real = load_settings_file(path);
  nlohmann::json renamed_json = settings_to_json(real);
  renamed_json["name"] = "Setting B";
  renamed_json["description"] = "a relabelled copy";
  const NamedSettings renamed = settings_from_json(renamed_json, "renamed copy");
  ASSERT_NE(real.name, renamed.name);

  SimTrialConfig a = trial(TaskKind::kClip, "high_fidelity", 5, 21);
  a.settings = real.engine;
  SimTrialConfig b = a;
  b.settings = renamed.engine;
  const Recorded ra = record(a);
  const Recorded rb = record(b);
  ASSERT_TRUE(ra.result.task_complete);
  ASSERT_GT(ra.samples.size(), 5000u);
  EXPECT_EQ(ra.result.dropped_samples, 0u);
  EXPECT_EQ(first_difference(ra, rb), -1);
  ASSERT_EQ(ra.events.size(), rb.events.size());
  for (std::size_t k = 0; k < ra.events.size(); ++k) EXPECT_TRUE(same_event(ra.events[k], rb.events[k])) << k;
  // The comparison can tell: the cogging amplitude one ulp higher, same name, parts the runs.
  SimTrialConfig c = a;
  c.settings.translation.cogging.amplitude = std::nextafter(a.settings.translation.cogging.amplitude, 1.0);
  EXPECT_NE(first_difference(ra, record(c)), -1);
}

// --- completion under every setting

TEST(TrialRunnerTest, BothTasksCompleteUnderEveryThesisSettingWithinTwoMinutes) {
  // Thesis participants took 1-3 min per trial; these trained simulated ones
  // take 10-40 s (longest, participant model of 9bb2dac: dissection
  // 27.7 s, clip 38.5 s, printed below; see the report on slow clip
  // trials for other seeds). Forces stay those of soft tissue: p95 below 3 N.
  for (TaskKind task : {TaskKind::kDissection, TaskKind::kClip}) {
    double longest_s = 0.0;
    for (const char* setting : kThesisSettings) {
      for (std::uint64_t person : {1ull, 2ull}) {
        const ForceSummary s = run_for_forces(trial(task, setting, person, 100 + person));
        const SimTrialResult& r = s.result;
        longest_s = std::max(longest_s, r.duration_s);
        const std::string what = std::string(to_string(task)) + ", " + setting + ", participant " +
                                 std::to_string(person);
        EXPECT_TRUE(r.task_complete) << what;
        EXPECT_EQ(r.stop_reason, StopReason::kTaskComplete) << what;
        EXPECT_LT(r.duration_s, 120.0) << what;
        EXPECT_EQ(r.device_status, DeviceStatus::kOk) << what;
        EXPECT_EQ(r.dropped_samples, 0u) << what;
        EXPECT_EQ(r.dropped_events, 0u) << what;
        EXPECT_GT(s.p95_N[1], 0.02) << what << ": the right tool touched tissue";
        EXPECT_LT(s.p95_N[0], 3.0) << what;
        EXPECT_LT(s.p95_N[1], 3.0) << what;
      }
    }
    std::printf("  %s: longest trial %.1f s\n", to_string(task), longest_s);
  }
}

// --- a device fault in the middle of a trial

class TrialRunnerFaultTest : public ::testing::TestWithParam<DeviceStatus> {};

TEST_P(TrialRunnerFaultTest, StopsTheForcesAndReportsTheFault) {
  const DeviceStatus fault = GetParam();
  SimTrialConfig c = trial(TaskKind::kDissection, "high_fidelity", 1, 101);
  // Find a moment when the right hand is pressing: the first update after
  // 3 s that ends 50 updates in a row with more than 0.2 N displayed on it.
  const Recorded clean = record(c);
  double t_fault_s = -1.0;
  std::size_t k_fault = 0;
  int pressing_for = 0;
  for (std::size_t k = 0; k < clean.samples.size(); ++k) {
    const LoopSample& s = clean.samples[k];
    pressing_for = magnitude(s.instrument[1].displayed_force_N) > 0.2 ? pressing_for + 1 : 0;
    if (s.t_s > 3.0 && pressing_for > 50) {
      t_fault_s = s.t_s;
      k_fault = k;
      break;
    }
  }
  ASSERT_GT(t_fault_s, 0.0) << "the right hand never pressed";

  c.inject_fault = std::make_pair(fault, t_fault_s);
  const Recorded faulty = record(c);
  EXPECT_EQ(faulty.result.stop_reason, StopReason::kDeviceFault);
  EXPECT_EQ(faulty.result.device_status, fault);
  EXPECT_FALSE(faulty.result.task_complete);
  // A read fault stops the update at t_fault before anything is logged; a
  // write fault after the VE step, also before logging. Every update before
  // is exactly the clean trial's.
  // So forces were on up to the fault, and none is logged after it.
  ASSERT_EQ(faulty.samples.size(), k_fault);
  for (std::size_t k = 0; k < k_fault; ++k) ASSERT_TRUE(same_sample(faulty.samples[k], clean.samples[k])) << k;
  for (const LoopSample& s : faulty.samples) {
    EXPECT_EQ(s.device_status, 0);
    for (const auto& in : s.instrument)
      for (double v : in.displayed_force_N) ASSERT_TRUE(std::isfinite(v));
  }

  // The same trial as a rig, to look at the device afterwards: motors at
  // zero and the amplifiers off.
  c.publish_samples = false;
  SimRig rig(c);
  EXPECT_EQ(rig.loop().run(), StopReason::kDeviceFault);
  EXPECT_EQ(rig.loop().device_status(), fault);
  EXPECT_LT(rig.loop().elapsed_s(), t_fault_s);
  EXPECT_GT(rig.loop().elapsed_s(), t_fault_s - 0.0015);
  for (int i = 0; i < 2; ++i)
    for (double f : rig.sim_device()->motor_force(i)) EXPECT_EQ(f, 0.0);
  DeviceReading reading;
  EXPECT_EQ(rig.device().read(reading), DeviceStatus::kNotActive);
}

INSTANTIATE_TEST_SUITE_P(AllInjectableFaults, TrialRunnerFaultTest,
                         ::testing::Values(DeviceStatus::kReadFailed, DeviceStatus::kNonFiniteReading,
                                           DeviceStatus::kOutOfRange, DeviceStatus::kWriteFailed),
                         [](const auto& info) { return std::string(to_string(info.param)); });

// --- the thesis' qualitative findings
//
// Like the thesis (3 repetitions per setting), each participant does each
// setting more than once: two trials (trial seeds 100 + p and 200 + p), and
// the participant's p95 is the mean of the two. Trial-to-trial variation is
// wide (a single clip trial can even reverse the effect), the mean of two
// is much steadier.

struct Comparison {
  double mean_ratio = 0.0;  // mean over participants of p95(setting) / p95(High Fidelity)
  double min_ratio = 1e9;
  int higher = 0;           // participants whose p95 rose
};

// The population the commands simulate by default (tests/testing/fitted_point.h).
PopulationParams fitted_population() { return testing::shipped_fitted_point(); }

double right_hand_p95_N(TaskKind task, const char* setting, std::uint64_t person) {
  double sum = 0.0;
  for (std::uint64_t trial_seed : {100 + person, 200 + person}) {
    SimTrialConfig c = trial(task, setting, person, trial_seed);
    c.population = fitted_population();
    sum += run_for_forces(c).p95_N[1];
  }
  return sum / 2.0;
}

// Right hand (cautery / clip applier) p95 force under `setting` against High
// Fidelity, participants 1..n on the same trials.
Comparison compare_to_high_fidelity(TaskKind task, const char* setting, int people) {
  Comparison c;
  for (int person = 1; person <= people; ++person) {
    const auto p = static_cast<std::uint64_t>(person);
    const double hf = right_hand_p95_N(task, "high_fidelity", p);
    const double other = right_hand_p95_N(task, setting, p);
    const double ratio = other / hf;
    c.mean_ratio += ratio / people;
    c.min_ratio = std::min(c.min_ratio, ratio);
    c.higher += other > hf ? 1 : 0;
    std::printf("  %s, %s / high fidelity, participant %d: p95 %.3f / %.3f N = %.2f\n", to_string(task),
                setting, person, other, hf, ratio);
  }
  return c;
}

TEST(TrialRunnerFindingsTest, NoForceFeedbackRaisesTheRightHandsPeakForces) {
  // Measured (6 trained participants, 2 trials each, the fitted
  // population; participant model 2 with the applier's push-through seen,
  // aaa2d28; the test prints each ratio): dissection ratios 2.05..2.44,
  // mean 2.27, 6 of 6 higher; clip 1.00..1.19, mean 1.12, 5 of 6 higher.
  // (Model 1, 9bb2dac, unfitted: clip 1.27..2.01. Much of that was the
  // applier pressed through the duct onto the structures below and held
  // there, which model 2's participant sees and corrects.) The thesis found
  // the rise in both tasks (Tables 3.5-3.6 give P values, not its size);
  // Wagner 2002 up to 2x in dissection. Required: dissection mean >= 1.35
  // (a marked rise) with at least 5 of 6 higher; clip mean >= 1.05 with at
  // least 4 of 6 higher (a model without the effect gives a mean near 1).
  const Comparison d = compare_to_high_fidelity(TaskKind::kDissection, "no_force_feedback", 6);
  EXPECT_GE(d.mean_ratio, 1.35);
  EXPECT_GE(d.higher, 5);
  const Comparison c = compare_to_high_fidelity(TaskKind::kClip, "no_force_feedback", 6);
  EXPECT_GE(c.mean_ratio, 1.05);
  EXPECT_GE(c.higher, 4);
}

TEST(TrialRunnerFindingsTest, InertiaAndOneNewtonSaturationChangeThePeakForcesLittle) {
  // The mildest of Table 3.1 for soft-tissue work: added inertia, and a 1 N
  // tip force limit that most contact forces stay under. Measured in
  // dissection (same participants, trials and population; printed):
  // inertia ratios 0.85..0.99, mean 0.91; saturation 1.00..1.69, mean 1.13
  // (it bites for the participant who presses past 1 N). Required: mean
  // within 0.7..1.3, well short of No Force Feedback's 2.27.
  for (const char* setting : {"inertia", "force_saturation"}) {
    const Comparison d = compare_to_high_fidelity(TaskKind::kDissection, setting, 6);
    EXPECT_GT(d.mean_ratio, 0.7) << setting;
    EXPECT_LT(d.mean_ratio, 1.3) << setting;
  }
}

}  // namespace
}  // namespace hapticlab
