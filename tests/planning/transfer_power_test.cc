// Power of a transfer design (planning/transfer_power.h): the counting of
// significant studies, the Wilson interval, the rows' order, that the
// same seed gives the same rows with one or two threads, and refusals.
// The group test is injected here; which test plan power uses is the
// analysis' business (tests/analysis/transfer/).
#include "planning/transfer_power.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "core/settings/settings_json.h"

namespace hapticlab::planning {
namespace {

EngineSettings power_settings(const std::string& name) {
  return load_settings_file(std::string(HAPTICLAB_SOURCE_DIR) + "/examples/settings/" + name + ".json").engine;
}

TransferDesign small_design() {
  TransferDesign d;
  d.test_settings = power_settings("high_fidelity");
  d.pre_trials = d.post_trials = d.retention_trials = 1;
  d.groups.push_back({"cheap", {{power_settings("no_force_feedback"), 4}}});
  d.groups.push_back({"haptic", {{power_settings("high_fidelity"), 4}}});
  return d;
}

TransferPowerOptions small_options(int jobs) {
  TransferPowerOptions o;
  o.per_group = {2};
  o.studies = 3;
  o.jobs = jobs;
  o.simulation.rate_Hz = 250.0;
  o.simulation.learning.force_free_share = 0.5;
  return o;
}

TEST(TransferPowerTest, CountsSignificantStudiesPerTestWithWilsonIntervalsAndTheSameRowsOnTwoThreads) {
  int calls = 0;
  // Significant when the group's median change is below the reference's.
  const GroupTest lower = [&](const std::vector<double>& a, const std::vector<double>& b) {
    ++calls;
    EXPECT_EQ(a.size(), 2u);
    EXPECT_EQ(b.size(), 2u);
    const double ma = 0.5 * (a[0] + a[1]), mb = 0.5 * (b[0] + b[1]);
    return ma < mb ? 0.01 : 0.5;
  };
  const TransferPower one = transfer_power(small_design(), small_options(1), lower);
  EXPECT_EQ(calls, 3 * 2);  // 3 studies x (post, retention) x 1 trained group
  ASSERT_EQ(one.rows.size(), 2u);
  EXPECT_EQ(one.rows[0].test, "post");
  EXPECT_EQ(one.rows[1].test, "retention");
  for (const TransferPowerRow& r : one.rows) {
    EXPECT_EQ(r.group, "haptic");
    EXPECT_EQ(r.reference, "cheap");
    EXPECT_EQ(r.per_group, 2);
    EXPECT_EQ(r.studies, 3);
    EXPECT_DOUBLE_EQ(r.power, r.significant / 3.0);
    EXPECT_LE(r.power_low, r.power);
    EXPECT_GE(r.power_high, r.power);
    EXPECT_TRUE(std::isfinite(r.median_effect_s));
  }
  EXPECT_EQ(one.trials_run, 3 * 2 * 2 * (1 + 4 + 1 + 1));
  const TransferPower two = transfer_power(small_design(), small_options(2), lower);
  ASSERT_EQ(two.rows.size(), one.rows.size());
  for (std::size_t i = 0; i < one.rows.size(); ++i) {
    EXPECT_EQ(two.rows[i].significant, one.rows[i].significant);
    EXPECT_EQ(two.rows[i].median_effect_s, one.rows[i].median_effect_s);
  }
  // A test that cannot be computed is not a study of the row.
  const GroupTest none = [](const std::vector<double>&, const std::vector<double>&) {
    return std::numeric_limits<double>::quiet_NaN();
  };
  TransferPowerOptions o = small_options(1);
  o.studies = 1;
  const TransferPower empty = transfer_power(small_design(), o, none);
  EXPECT_EQ(empty.rows[0].studies, 0);
  EXPECT_TRUE(std::isnan(empty.rows[0].power));
  // p < alpha counts, p >= alpha does not; Wilson's interval for 1 of 1 is
  // [0.2065, 1] (z = 1.96: 1/(1 + z²) = 0.2065).
  const TransferPower all = transfer_power(
      small_design(), o, [](const std::vector<double>&, const std::vector<double>&) { return 0.0499; });
  EXPECT_EQ(all.rows[0].significant, 1);
  EXPECT_EQ(all.rows[0].power, 1.0);
  EXPECT_NEAR(all.rows[0].power_low, 0.2065, 1e-4);
  const TransferPower at_alpha = transfer_power(
      small_design(), o, [](const std::vector<double>&, const std::vector<double>&) { return 0.05; });
  EXPECT_EQ(at_alpha.rows[0].significant, 0);
}

TEST(TransferPowerTest, WithoutAPreTestGroupsAreComparedOnTheTestsTimeItselfAndWithoutRetentionOnlyOnThePostTest) {
  TransferDesign d = small_design();
  d.pre_trials = 0;
  d.retention_trials = 0;
  TransferPowerOptions o = small_options(1);
  o.studies = 1;
  int calls = 0;
  const TransferPower p = transfer_power(d, o, [&](const std::vector<double>& a, const std::vector<double>& b) {
    ++calls;
    for (double v : a) EXPECT_GT(v, 1.0);  // a trial's time [s], not a change
    for (double v : b) EXPECT_GT(v, 1.0);
    return 0.5;
  });
  EXPECT_EQ(calls, 1);
  ASSERT_EQ(p.rows.size(), 1u);
  EXPECT_EQ(p.rows[0].test, "post");
  EXPECT_EQ(p.trials_run, 2 * 2 * (4 + 1));  // 2 groups x 2 people x (4 training + 1 post)
}

TEST(TransferPowerTest, RefusesBadOptionsByName) {
  const GroupTest any = [](const std::vector<double>&, const std::vector<double>&) { return 0.5; };
  auto refused = [&](TransferPowerOptions o, const std::string& named) {
    try {
      (void)transfer_power(small_design(), o, any);
      ADD_FAILURE() << named << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(named), std::string::npos) << e.what();
    }
  };
  TransferPowerOptions o = small_options(1);
  o.per_group = {};
  refused(o, "participants per group: none given");
  o = small_options(1);
  o.per_group = {0};
  refused(o, "participants per group is 0");
  o = small_options(1);
  o.studies = 0;
  refused(o, "studies is 0");
  o = small_options(1);
  o.alpha = 1.0;
  refused(o, "alpha is 1");
  o = small_options(1);
  o.jobs = 0;
  refused(o, "jobs is 0");
}

}  // namespace
}  // namespace hapticlab::planning
