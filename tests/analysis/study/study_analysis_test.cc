#include "analysis/study/headline_format.h"
#include "analysis/study/statistics_tables.h"
#include "analysis/study/study_analysis.h"

#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/io/long_csv.h"
#include "analysis/stats/block_table.h"
#include "analysis/stats/data_error.h"
#include "analysis/stats/friedman.h"
#include "analysis/stats/ks_bootstrap.h"
#include "analysis/study/metrics_csv.h"
#include "analysis/study/trial_reader.h"
#include "study/synthetic_study_db.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;
using testing::trial_force_N;

constexpr double kStudyTolerance = 1e-9;

class StudyAnalysisTest : public ::testing::Test {
 protected:
  void SetUp() override {
    db_path_ = dir_.path() / "study.db";
    testing::build_synthetic_study(db_path_);
  }
  StudyAnalysis analyze(AnalysisOptions options = {}) {
    options.ks_block_length = 2;  // the synthetic series are 5-6 samples long
    options.ks_stride = 1;
    options.ks_resamples = 200;
    return analyze_study_file(db_path_, options);
  }
  testing::ScratchDir dir_;
  std::filesystem::path db_path_;
};

const TrialRecord& find_trial(const StudyAnalysis& a, const std::string& participant, const std::string& setting,
                              int rep) {
  for (const auto& t : a.trials)
    if (t.participant == participant && t.setting == setting && t.repetition == rep) return t;
  throw std::runtime_error("no such trial");
}

TEST_F(StudyAnalysisTest, CountsAbortedAndUnrunTrials) {
  const StudyAnalysis a = analyze();
  EXPECT_EQ(a.counts.analysed, 10u);
  EXPECT_EQ(a.counts.complete, 10u);
  EXPECT_EQ(a.counts.aborted_excluded, 1u);
  EXPECT_EQ(a.counts.aborted_included, 0u);
  EXPECT_EQ(a.counts.not_run, 1u);
  EXPECT_EQ(a.counts.without_window, 0u);
  EXPECT_EQ(a.control, "High Fidelity");
  EXPECT_EQ(a.settings, (std::vector<std::string>{"High Fidelity", "No Force Feedback", "Cogging"}));
  EXPECT_EQ(a.participants, (std::vector<std::string>{"P1", "P2"}));
  for (const auto& t : a.trials) EXPECT_EQ(t.status, "complete");
}

TEST_F(StudyAnalysisTest, IncludeAbortedTakesThemIn) {
  AnalysisOptions o;
  o.include_aborted = true;
  const StudyAnalysis a = analyze(o);
  EXPECT_EQ(a.counts.analysed, 11u);
  EXPECT_EQ(a.counts.aborted_included, 1u);
  EXPECT_EQ(a.counts.aborted_excluded, 0u);
  // P1's Cogging now has 3 repetitions against 2: balancing drops one per hand.
  for (const auto& r : a.friedman) {
    if (r.participant == "P1" && r.hand == -1 && r.measure == Measure::kForceP95) {
      EXPECT_EQ(r.test.replicates, 2u);
      EXPECT_EQ(r.test.dropped, 2u);
    }
  }
}

// The measures match the hand-worked values of synthetic_study_db.h.
TEST_F(StudyAnalysisTest, MetricsMatchHandWorkedValues) {
  const StudyAnalysis a = analyze();
  const TrialRecord& t = find_trial(a, "P1", "No Force Feedback", 2);
  const double f = trial_force_N(1, 1, 2);
  ASSERT_TRUE(t.window.has_value());
  EXPECT_NEAR(t.window->start_s, 0.25, kStudyTolerance);
  EXPECT_NEAR(t.window->end_s, 0.875, kStudyTolerance);
  EXPECT_NEAR(t.value(Measure::kCompletionTime, 0), 0.625, kStudyTolerance);
  EXPECT_NEAR(t.value(Measure::kForceMedian, 0), 3 * f, kStudyTolerance);
  EXPECT_NEAR(t.value(Measure::kForceP95, 0), 5 * f, kStudyTolerance);
  EXPECT_NEAR(t.value(Measure::kForceMedian, 1), 1.5 * f, kStudyTolerance);
  EXPECT_NEAR(t.value(Measure::kForceP95, 1), 2.5 * f, kStudyTolerance);
  EXPECT_NEAR(t.value(Measure::kSpeedMedian, 0), 4.5 / 64, kStudyTolerance);
  EXPECT_NEAR(t.value(Measure::kPathLength, 1), 2 * 45.0 / 1024, kStudyTolerance);
  EXPECT_EQ(t.hands[0].samples, 6u);
  EXPECT_EQ(t.hands[0].force_samples, 5u);
}

// Table 3.4 for P1, 95th percentile force: hands are blocks, repetitions
// replicates, i.e. MATLAB friedman(X, 2) with X rows (left rep 1, left rep 2,
// right rep 1, right rep 2) and columns HF, NFF, Cogging.
TEST_F(StudyAnalysisTest, FriedmanPerParticipantUsesHandsAsBlocks) {
  const StudyAnalysis a = analyze();
  std::vector<std::vector<double>> x;
  for (double hand_scale : {5.0, 2.5})
    for (int rep = 1; rep <= 2; ++rep)
      x.push_back({hand_scale * trial_force_N(1, 0, rep), hand_scale * trial_force_N(1, 1, rep),
                   hand_scale * trial_force_N(1, 2, rep)});
  const TestResult expected = friedman_test(BlockTable::from_matrix(x, 2));
  bool found = false;
  for (const auto& r : a.friedman) {
    if (r.participant != "P1" || r.hand != -1 || r.measure != Measure::kForceP95) continue;
    found = true;
    ASSERT_TRUE(r.test.result.has_value()) << r.test.note;
    EXPECT_NEAR(r.test.result->p, expected.p, 1e-12);
    EXPECT_NEAR(r.test.result->statistic, expected.statistic, 1e-12);
    EXPECT_EQ(r.test.result->blocks, 2u);
    EXPECT_EQ(r.test.replicates, 2u);
  }
  EXPECT_TRUE(found);
  // Completion time is the same everywhere: all ties, p = 1.
  for (const auto& r : a.friedman)
    if (r.measure == Measure::kCompletionTime && r.test.result) {
      EXPECT_DOUBLE_EQ(r.test.result->p, 1.0);
    }
}

// Tables 3.5/3.6: HF vs NFF over the 4 participant × hand blocks of P1 and
// P2; HF vs Cogging only P1's 2 blocks.
TEST_F(StudyAnalysisTest, PairwiseAgainstControl) {
  const StudyAnalysis a = analyze();
  EXPECT_EQ(a.sidak_m, 2u);
  EXPECT_NEAR(a.sidak_level, 1 - std::sqrt(0.95), 1e-12);
  std::vector<std::vector<double>> x;
  for (int p = 1; p <= 2; ++p)
    for (double hand_scale : {3.0, 1.5})
      for (int rep = 1; rep <= 2; ++rep)
        x.push_back({hand_scale * trial_force_N(p, 0, rep), hand_scale * trial_force_N(p, 1, rep)});
  const TestResult expected = friedman_test(BlockTable::from_matrix(x, 2));
  int seen = 0;
  for (const auto& c : a.pairwise) {
    if (c.measure != Measure::kForceMedian) continue;
    ++seen;
    if (c.setting == "No Force Feedback") {
      EXPECT_EQ(c.participants, 2u);
      EXPECT_EQ(c.blocks, 4u);
      ASSERT_TRUE(c.p.has_value());
      EXPECT_NEAR(*c.p, expected.p, 1e-12);
      EXPECT_EQ(c.significant, *c.p < a.sidak_level);
    } else {
      EXPECT_EQ(c.setting, "Cogging");
      EXPECT_EQ(c.participants, 1u);
      EXPECT_EQ(c.blocks, 2u);
    }
  }
  EXPECT_EQ(seen, 2);
}

// P2 lacks Cogging: the whole design is incomplete and not a BIBD, so
// Skillings–Mack is used.
TEST_F(StudyAnalysisTest, WholeDesignPicksSkillingsMack) {
  const StudyAnalysis a = analyze();
  ASSERT_EQ(a.whole_design.size(), 5u);
  for (const auto& r : a.whole_design) {
    if (r.measure == Measure::kForceP95) {
      ASSERT_TRUE(r.test.result.has_value()) << r.test.note;
      EXPECT_EQ(r.test.result->method, "Skillings-Mack");
      EXPECT_EQ(r.test.result->blocks, 4u);
    }
  }
}

// A study's records made by hand, for the designs the synthetic database
// does not have: `design` lists each participant's settings. Values are
// distinct everywhere (no ties), two repetitions per cell.
StudyAnalysis hand_made(const std::vector<std::pair<std::string, std::vector<std::string>>>& design,
                        const std::set<std::string>& missing = {}) {
  StudyAnalysis a;
  a.options.ks = false;
  a.control = "HF";
  a.tasks = {"clip"};
  a.settings = {"HF", "A", "B"};
  const std::map<std::string, double> base = {{"HF", 1.0}, {"A", 1.5}, {"B", 2.2}};
  int who = 0;
  for (const auto& [participant, settings] : design) {
    a.participants.push_back(participant);
    int position = 0;
    for (int rep = 1; rep <= 2; ++rep) {
      for (const std::string& setting : settings) {
        // "P2 A 2": that participant's second repetition at A timed out.
        if (missing.count(participant + " " + setting + " " + std::to_string(rep))) continue;
        TrialRecord t;
        t.participant = participant;
        t.task = "clip";
        t.setting = setting;
        t.repetition = rep;
        t.position = ++position;
        t.status = "complete";
        t.window = TaskWindow{0.0, 60.0 + position};
        for (int h = 0; h < 2; ++h) {
          HandMetrics& m = t.hands[static_cast<std::size_t>(h)];
          const double v = base.at(setting) + 0.1 * h + 0.01 * who + 0.001 * rep;
          m.force_median_N = v / 2;
          m.force_p95_N = v;
          m.speed_median_m_per_s = 0.01 * v;
          m.path_length_m = 0.5 * v;
        }
        a.trials.push_back(t);
      }
    }
    ++who;
  }
  run_statistics(a);
  return a;
}

const WholeDesignRow& p95_row(const StudyAnalysis& a) {
  for (const auto& r : a.whole_design)
    if (r.measure == Measure::kForceP95) return r;
  throw std::runtime_error("no whole-design row for p95 force");
}

// Everyone did every setting: the classic Friedman over participant × hand
// blocks (per-cell medians). Every block ranks HF < A < B: rank sums 6, 12,
// 18 over 6 blocks, statistic 12/(6·3·4)·(36 + 144 + 324) − 3·6·4 = 12.
TEST(WholeDesignTest, CompleteDesignUsesFriedman) {
  const StudyAnalysis a = hand_made({{"P1", {"HF", "A", "B"}}, {"P2", {"HF", "A", "B"}}, {"P3", {"HF", "A", "B"}}});
  const WholeDesignRow& r = p95_row(a);
  ASSERT_TRUE(r.test.result.has_value()) << r.test.note;
  EXPECT_EQ(r.test.result->method.rfind("Friedman", 0), 0u) << r.test.result->method;
  EXPECT_EQ(r.test.result->blocks, 6u);
  EXPECT_NEAR(r.test.result->statistic, 12.0, kStudyTolerance);
}

// Pairs of 3 settings, each pair once per participant, both hands: a
// balanced incomplete block design (t = 3, k = 2, b = 6, r = 4, λ = 2), so
// Durbin. In every block the lower setting ranks 1: HF gets 1 four times,
// B gets 2 four times, A half each: rank sums 4, 6, 8. Durbin's
// T = 12(t−1)/(r·t·(k−1)(k+1)) · Σ(R − r(k+1)/2)² = 24/36 · (4 + 0 + 4) = 16/3.
TEST(WholeDesignTest, BalancedIncompleteDesignUsesDurbin) {
  const StudyAnalysis a = hand_made({{"P1", {"HF", "A"}}, {"P2", {"HF", "B"}}, {"P3", {"A", "B"}}});
  const WholeDesignRow& r = p95_row(a);
  ASSERT_TRUE(r.test.result.has_value()) << r.test.note;
  EXPECT_EQ(r.test.result->method.rfind("Durbin", 0), 0u) << r.test.result->method;
  EXPECT_EQ(r.test.result->blocks, 6u);
  EXPECT_NEAR(r.test.result->statistic, 16.0 / 3.0, kStudyTolerance);
}

const PairwiseCell& pairwise_p95(const StudyAnalysis& a, const std::string& setting) {
  for (const auto& c : a.pairwise)
    if (c.setting == setting && c.measure == Measure::kForceP95) return c;
  throw std::runtime_error("no pairwise cell for " + setting);
}

// One trial short (a time-out) must not make a comparison N/A: the blocks
// are balanced to equal repetitions, keeping the most observations.
// P1 and P2 have 2 repetitions at HF and A; P3 lost its second A: per hand,
// r = 2 keeps 2·2·4 = 16 values (P3 left out), r = 1 keeps 1·2·6 = 12.
TEST(PairwiseBalanceTest, ATrialShortLeavesOutTheShortBlockWhenThatKeepsMore) {
  const StudyAnalysis a = hand_made({{"P1", {"HF", "A"}}, {"P2", {"HF", "A"}}, {"P3", {"HF", "A"}}}, {"P3 A 2"});
  const PairwiseCell& c = pairwise_p95(a, "A");
  ASSERT_TRUE(c.p.has_value()) << c.note;
  EXPECT_EQ(c.blocks, 4u);
  EXPECT_EQ(c.participants, 2u);
  // Dropped: P3's 2 + 1 values per hand.
  EXPECT_EQ(c.note, "balanced to 2 repetition(s) per cell: 6 observation(s) dropped, 2 block(s) left out");
  // What is left is exactly the study without P3.
  const StudyAnalysis without_p3 = hand_made({{"P1", {"HF", "A"}}, {"P2", {"HF", "A"}}});
  EXPECT_DOUBLE_EQ(*c.p, *pairwise_p95(without_p3, "A").p);
}

// With two participants, one short: r = 1 keeps 1·2·4 = 8 of the 14
// values, r = 2 keeps 2·2·2 = 8 too; the tie goes to more blocks (both
// participants), dropping P1's second repetitions and P2's second HF.
TEST(PairwiseBalanceTest, OnATieMoreBlocksWin) {
  const StudyAnalysis a = hand_made({{"P1", {"HF", "A"}}, {"P2", {"HF", "A"}}}, {"P2 A 2"});
  const PairwiseCell& c = pairwise_p95(a, "A");
  ASSERT_TRUE(c.p.has_value()) << c.note;
  EXPECT_EQ(c.blocks, 4u);
  EXPECT_EQ(c.participants, 2u);
  EXPECT_EQ(c.note, "balanced to 1 repetition(s) per cell: 6 observation(s) dropped");
}

// Force rises with the repetition, and repetitions come in trial order: a
// positive correlation; completion time is constant, so it has none.
TEST_F(StudyAnalysisTest, TrialNumberCorrelations) {
  const StudyAnalysis a = analyze();
  bool force_seen = false;
  bool time_seen = false;
  for (const auto& r : a.correlations) {
    if (r.participant != "P1") continue;
    if (r.measure == Measure::kForceP95 && r.hand == 0) {
      force_seen = true;
      ASSERT_TRUE(r.result.has_value()) << r.note;
      EXPECT_GT(r.result->r, 0.0);
      EXPECT_EQ(r.result->n, 6u);
    }
    if (r.measure == Measure::kCompletionTime) {
      time_seen = true;
      EXPECT_EQ(r.hand, -1);
      EXPECT_FALSE(r.result.has_value());
      EXPECT_FALSE(r.note.empty());
    }
  }
  EXPECT_TRUE(force_seen);
  EXPECT_TRUE(time_seen);
}

// The KS rows are the bootstrap of exactly the series the header of
// synthetic_study_db.h describes. Left-hand force, High Fidelity vs No Force
// Feedback (the first comparison): inside the window the samples above 1 mN
// are k·f, k = 1..5, with f = base + rep/8 + participant/16, so P1 has HF
// f = 1.1875, 1.3125 and NFF f = 2.1875, 2.3125, and P2 each 1/16 more.
// The analysis seeds comparison c with seed·0x9E3779B97F4A7C15 + c. The same
// bootstrap run on those hand-built series must give the same ranges, bit
// for bit: a leaked out-of-window sample (100 N), the wrong hand or a
// missing repetition changes them.
TEST_F(StudyAnalysisTest, KsRowIsTheBootstrapOfTheHandWorkedSeries) {
  const StudyAnalysis a = analyze();
  EXPECT_EQ(a.ks.size(), 1u * 2 * 2 * 2);  // task × hand × {force, speed} × 2 settings
  const KsRow& row = a.ks.at(0);
  ASSERT_EQ(row.hand, 0);
  ASSERT_EQ(row.quantity, "force");
  ASSERT_EQ(row.setting, "No Force Feedback");
  ASSERT_TRUE(row.result.has_value()) << row.note;

  const auto series = [](double f) {
    std::vector<double> v;
    for (int k = 1; k <= 5; ++k) v.push_back(k * f);
    return v;
  };
  std::vector<ParticipantRepetitions> data;
  for (int p = 1; p <= 2; ++p) {
    ParticipantRepetitions reps;
    reps.participant = "P" + std::to_string(p);
    for (int rep = 1; rep <= 2; ++rep) {
      reps.control.push_back(series(trial_force_N(p, 0, rep)));
      reps.other.push_back(series(trial_force_N(p, 1, rep)));
    }
    data.push_back(reps);
  }
  KsBootstrapOptions o;
  o.resamples = 200;
  o.block_length = 2;
  o.seed = 1 * 0x9E3779B97F4A7C15ULL + 1;
  const KsBootstrapResult expected = ks_block_bootstrap(data, o);
  EXPECT_EQ(row.result->intra.low, expected.intra.low);
  EXPECT_EQ(row.result->intra.high, expected.intra.high);
  EXPECT_EQ(row.result->inter.low, expected.inter.low);
  EXPECT_EQ(row.result->inter.high, expected.inter.high);
  EXPECT_EQ(row.result->significant, expected.significant);
  EXPECT_EQ(row.result->participants_used, 2u);
  // and the ranges are not degenerate, so the comparison above means something
  EXPECT_LT(expected.intra.low, expected.intra.high);
  EXPECT_LT(expected.inter.low, expected.inter.high);
}

TEST_F(StudyAnalysisTest, MetricsCsvOneRowPerTrialAndHand) {
  const StudyAnalysis a = analyze();
  std::ostringstream out;
  write_metrics_csv(a, out);
  const LongCsv csv = LongCsv::parse(out.str(), "metrics.csv");
  ASSERT_EQ(csv.row_count(), 20u);
  for (const char* column : {"participant", "task", "setting", "repetition", "trial_number", "instrument",
                             "completion_time_s", "force_median_N", "force_p95_N", "speed_median_m_per_s",
                             "path_length_m"}) {
    EXPECT_NO_THROW(csv.column(column)) << column;
  }
  int checked = 0;
  for (std::size_t row = 0; row < csv.row_count(); ++row) {
    if (csv.text(row, csv.column("participant")) != "P2" || csv.text(row, csv.column("setting")) != "High Fidelity" ||
        csv.text(row, csv.column("repetition")) != "1" || csv.text(row, csv.column("instrument")) != "1")
      continue;
    ++checked;
    const double f = trial_force_N(2, 0, 1);
    EXPECT_NEAR(csv.number(row, csv.column("force_p95_N")), 2.5 * f, 1e-7);
    EXPECT_NEAR(csv.number(row, csv.column("completion_time_s")), 0.625, 1e-9);
    EXPECT_NEAR(csv.number(row, csv.column("path_length_m")), 45.0 / 1024, 1e-9);
    EXPECT_EQ(csv.text(row, csv.column("task")), "dissection");
    // P2's schedule interleaves: rep 1 runs NFF (position 1), then HF (2).
    EXPECT_EQ(csv.text(row, csv.column("trial_number")), "2");
  }
  EXPECT_EQ(checked, 1);
}

// %.9g printed 0.1 + 0.2 as 0.3 and 1/3 as 0.333333333, which read back as
// other doubles; the shortest round-trip form reads back exactly.
TEST(MetricsCsvTest, NumbersReadBackToTheSameDouble) {
  StudyAnalysis a;
  TrialRecord t;
  t.trial_id = 1;
  t.participant = "P1, \"left-handed\"";  // quoting, too
  t.task = "clip";
  t.setting = "HiFi";
  t.window = TaskWindow{0.1, 0.1 + 0.2};
  t.hands[0] = {3, 3, 1.0 / 3.0, 2.0 / 3.0, 1e-300 * 3.0, 123456.78901234567};
  t.hands[1] = {3, 0, std::nan(""), std::nan(""), 0.1, 0.7};
  a.trials.push_back(t);
  std::ostringstream out;
  write_metrics_csv(a, out);
  const LongCsv csv = LongCsv::parse(out.str(), "metrics.csv");
  ASSERT_EQ(csv.row_count(), 2u);
  EXPECT_EQ(csv.text(0, csv.column("participant")), t.participant);
  EXPECT_EQ(csv.number(0, csv.column("task_end_s")), 0.1 + 0.2);
  EXPECT_EQ(csv.text(0, csv.column("task_end_s")), "0.30000000000000004");
  EXPECT_EQ(csv.text(0, csv.column("task_start_s")), "0.1");
  EXPECT_EQ(csv.number(0, csv.column("completion_time_s")), (0.1 + 0.2) - 0.1);
  EXPECT_EQ(csv.number(0, csv.column("force_median_N")), 1.0 / 3.0);
  EXPECT_EQ(csv.number(0, csv.column("force_p95_N")), 2.0 / 3.0);
  EXPECT_EQ(csv.number(0, csv.column("speed_median_m_per_s")), 1e-300 * 3.0);
  EXPECT_EQ(csv.number(0, csv.column("path_length_m")), 123456.78901234567);
  EXPECT_EQ(csv.text(1, csv.column("force_median_N")), "");  // missing stays empty
  EXPECT_EQ(csv.text(1, csv.column("note")), "no sample reached the contact threshold: force measures missing");
  // A window with no sample at all: the events and samples disagree (the
  // note blamed the contact threshold).
  a.trials.front().hands[1] = {0, 0, std::nan(""), std::nan(""), std::nan(""), std::nan("")};
  std::ostringstream again;
  write_metrics_csv(a, again);
  EXPECT_EQ(LongCsv::parse(again.str(), "metrics.csv").text(1, csv.column("note")),
            "the task window holds none of the trial's samples: its events and samples disagree; measures missing, "
            "the completion time is the events' alone");
}

// Events of another clock than the samples (a wall-clock contact end beside
// loop times, an insertion at -500 s) made a completion time of 3600 s for
// a 2 s trial, with no note, and it entered the Time test. Such a trial's
// measures are missing, saying why; within the slack (samples dropped at
// an end) the window stands.
TEST(TrialAccumulatorTest, ATaskWindowReachingPastTheSamplesIsAProblemNotAMeasure) {
  const AnalysisOptions options;
  const auto measured = [&](double insertion_s, double contact_end_s) {
    const std::vector<TaskEvent> events = {{insertion_s, TaskEventType::kInsertionPassed, 0, 0},
                                           {0.5, TaskEventType::kContactStart, 0, 0},
                                           {contact_end_s, TaskEventType::kContactEnd, 0, 0}};
    TrialAccumulator acc;
    acc.start(events, options);
    for (int k = 0; k <= 2000; ++k)  // 0 .. 2 s at 1 kHz, a 1 N push
      for (std::size_t hand = 0; hand < 2; ++hand)
        acc.add(hand, 0.001 * k, Vec3d{0.0, 0.0, -0.1}, Vec3d{0.0, 0.0, 0.0}, Vec3d{0.0, 0.0, 1.0});
    TrialRecord rec;
    acc.finish(rec);
    return rec;
  };
  const TrialRecord sound = measured(0.1, 1.5);
  EXPECT_EQ(sound.problem, "");
  ASSERT_TRUE(sound.window.has_value());
  EXPECT_DOUBLE_EQ(sound.window->end_s - sound.window->start_s, 1.4);
  EXPECT_TRUE(measured(0.1, 2.4).window.has_value());  // 0.4 s past the last sample: within the slack

  const TrialRecord late = measured(0.1, 3600.0);
  EXPECT_FALSE(late.window.has_value());
  EXPECT_EQ(late.problem, "the task window ends at 3600 s (its last contact), after the last sample at 2 s: its "
                          "events and samples disagree (two clocks, or an edited file); measures and completion time "
                          "missing");
  EXPECT_TRUE(std::isnan(late.value(Measure::kCompletionTime, 0)));
  const TrialRecord early = measured(-500.0, 1.5);
  EXPECT_FALSE(early.window.has_value());
  EXPECT_THAT(early.problem, HasSubstr("the task window starts at -500 s (its first 20 mm insertion), before the "
                                       "first sample at 0 s"));
}

TEST_F(StudyAnalysisTest, HeadlineTablesShowThesisLayout) {
  const std::string text = format_headline_tables(analyze());
  EXPECT_THAT(text, HasSubstr("Table 3.4"));
  EXPECT_THAT(text, HasSubstr("Table 3.5"));
  EXPECT_THAT(text, HasSubstr("dissection P1"));
  EXPECT_THAT(text, HasSubstr("No Force Feedback (2)"));
  EXPECT_THAT(text, HasSubstr("Cogging (1)"));
  EXPECT_THAT(text, HasSubstr("aborted left out: 1"));
}

// Trials are read on several threads, each with its own connection; the
// records come back in schedule order and equal to the bit.
TEST_F(StudyAnalysisTest, ResultsDoNotDependOnTheThreadCount) {
  AnalysisOptions one;
  one.threads = 1;
  AnalysisOptions three;
  three.threads = 3;
  const StudyAnalysis a = analyze(one);
  const StudyAnalysis b = analyze(three);
  ASSERT_EQ(a.trials.size(), b.trials.size());
  ASSERT_GT(a.trials.size(), 3u);
  for (std::size_t i = 0; i < a.trials.size(); ++i) {
    const TrialRecord& x = a.trials[i];
    const TrialRecord& y = b.trials[i];
    EXPECT_EQ(x.trial_id, y.trial_id);
    EXPECT_EQ(x.problem, y.problem);
    for (std::size_t h = 0; h < 2; ++h) {
      for (Measure m : kAllMeasures) {
        const double u = x.value(m, static_cast<int>(h));
        const double v = y.value(m, static_cast<int>(h));
        EXPECT_TRUE((std::isnan(u) && std::isnan(v)) || u == v) << x.trial_id << " " << measure_column(m);
      }
      EXPECT_EQ(x.force_quantiles_N[h], y.force_quantiles_N[h]);
      EXPECT_EQ(x.speed_series_m_per_s[h], y.speed_series_m_per_s[h]);
    }
  }
  EXPECT_EQ(format_headline_tables(a), format_headline_tables(b));
  // The KS comparisons run on three threads in b: the same rows, in order.
  ASSERT_EQ(a.ks.size(), b.ks.size());
  ASSERT_EQ(a.ks.size(), 8u);
  for (std::size_t i = 0; i < a.ks.size(); ++i) {
    const KsRow& x = a.ks[i];
    const KsRow& y = b.ks[i];
    EXPECT_EQ(x.task + x.quantity + x.setting + std::to_string(x.hand), y.task + y.quantity + y.setting + std::to_string(y.hand));
    EXPECT_EQ(x.note, y.note);
    ASSERT_EQ(x.result.has_value(), y.result.has_value()) << i;
    if (!x.result) continue;
    EXPECT_EQ(x.result->intra.low, y.result->intra.low) << i;
    EXPECT_EQ(x.result->intra.high, y.result->intra.high) << i;
    EXPECT_EQ(x.result->inter.low, y.result->inter.low) << i;
    EXPECT_EQ(x.result->inter.high, y.result->inter.high) << i;
  }
  std::ostringstream csv_a, csv_b;
  write_metrics_csv(a, csv_a);
  write_metrics_csv(b, csv_b);
  EXPECT_EQ(csv_a.str(), csv_b.str());
}

TEST_F(StudyAnalysisTest, ErrorsNameTheProblem) {
  EXPECT_THAT([&] { (void)analyze_study_file(dir_.path() / "missing.db", {}); },
              ::testing::ThrowsMessage<DataError>(HasSubstr("missing.db")));
  AnalysisOptions o;
  o.control_setting = "Nope";
  EXPECT_THAT([&] { (void)analyze(o); }, ::testing::ThrowsMessage<DataError>(HasSubstr("'High Fidelity'")));
  AnalysisOptions bad;
  bad.alpha = 1.5;
  EXPECT_THAT([&] { (void)analyze_study_file(db_path_, bad); },
              ::testing::ThrowsMessage<DataError>(HasSubstr("alpha is 1.5")));
  AnalysisOptions wrong_study;
  wrong_study.study_id = 99;
  EXPECT_THAT([&] { (void)analyze(wrong_study); }, ::testing::ThrowsMessage<DataError>(HasSubstr("synthetic")));
}

TEST(FormatTest, PValuesLikeTheThesis) {
  EXPECT_EQ(format_p(0.10), "0.1");
  EXPECT_EQ(format_p(0.0071), "0.0071");
  EXPECT_EQ(format_p(6.3e-5), "6E-5");
  EXPECT_EQ(format_p(9.6e-5), "1E-4");
  EXPECT_EQ(format_p(1.0), "1");
  // Next to a decision level, as many digits as it takes to see the side:
  // 0.00729 and 0.00734 against the Šidák level 0.0073008 (m = 7) used to
  // print as "0.0073**" and "0.0073".
  const double sidak = 1.0 - std::pow(0.95, 1.0 / 7.0);  // 0.0073008
  EXPECT_EQ(format_level(sidak), "0.007301");
  EXPECT_EQ(format_p(0.00729, sidak), "0.00729");
  EXPECT_EQ(format_p(0.00734, sidak), "0.00734");
  EXPECT_EQ(format_p(0.0073005, sidak), "0.007300");  // below 0.007301 as printed
  EXPECT_EQ(format_p(0.0071, sidak), "0.0071");         // clear of it: thesis form
  EXPECT_EQ(format_p(6.3e-5, sidak), "6E-5");
  EXPECT_EQ(format_p(0.05, 0.05), "0.05");              // not below: not significant
  EXPECT_EQ(format_p(0.0496, 0.05), "0.0496");          // "0.05" would look not significant
  EXPECT_EQ(format_p(0.0504, 0.05), "0.0504");
  EXPECT_EQ(setting_abbreviation("No Force Feedback"), "NFF");
  EXPECT_EQ(setting_abbreviation("Inertia + Backlash"), "I+B");
  EXPECT_EQ(setting_abbreviation("Cogging"), "Cogging");
  // A dose series' settings differ only in the number: it stays whole.
  EXPECT_EQ(setting_abbreviation("Insertion friction, dynamic_level_N = 0.45"), "IFD=0.45");
  EXPECT_EQ(setting_abbreviation("Insertion friction, dynamic_level_N = 1e-05"), "IFD=1e-05");
}

}  // namespace
}  // namespace hapticlab::analysis
