#include "analysis/stats/kolmogorov_smirnov.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"
#include "analysis/stats/distributions.h"

namespace hapticlab::analysis {
namespace {

// D is a difference of multiples of 1/n: exact up to rounding.
constexpr double kExact = 1e-12;

TEST(KolmogorovSmirnovTest, DisjointSamplesHaveDOne) {
  EXPECT_NEAR(ks_statistic(std::vector<double>{1, 2, 3}, std::vector<double>{4, 5, 6}), 1.0, kExact);
}

// a = {1,2,3,4}, b = {3,4,5,6}: F1 − F2 after 1: 0.25, 2: 0.5, 3: 0.75 − 0.25,
// 4: 1 − 0.5, 5: 1 − 0.75 -> D = 0.5.
TEST(KolmogorovSmirnovTest, HandWorkedOverlap) {
  EXPECT_NEAR(ks_statistic(std::vector<double>{4, 3, 2, 1}, std::vector<double>{3, 4, 5, 6}), 0.5,
              kExact);
}

// Ties across samples: a = {1,2,2,3}, b = {2,2,2,2}. After 1: 0.25 − 0;
// after 2 (both step together): 0.75 − 1; after 3: 0 -> D = 0.25. Measuring
// between the two steps at 2 would wrongly give 0.5 or 0.75.
TEST(KolmogorovSmirnovTest, TiesStepTogether) {
  EXPECT_NEAR(ks_statistic(std::vector<double>{1, 2, 2, 3}, std::vector<double>{2, 2, 2, 2}), 0.25,
              kExact);
}

TEST(KolmogorovSmirnovTest, IdenticalSamplesHaveDZero) {
  const std::vector<double> a = {0.1, 0.5, 0.5, 0.9};
  EXPECT_EQ(ks_statistic(a, a), 0.0);
  EXPECT_EQ(ks_test(a, a).p, 1.0);
}

// Kolmogorov's limiting distribution: the classical critical values
// K(1.2238) = 0.90, K(1.3581) = 0.95, K(1.6276) = 0.99, and K(1) = 0.7300.
TEST(KolmogorovSmirnovTest, KolmogorovDistributionKnownValues) {
  EXPECT_NEAR(kolmogorov_upper(1.2238), 0.10, 1e-4);
  EXPECT_NEAR(kolmogorov_upper(1.3581), 0.05, 1e-4);
  EXPECT_NEAR(kolmogorov_upper(1.6276), 0.01, 1e-4);
  EXPECT_NEAR(kolmogorov_upper(1.0), 0.2700, 1e-4);
  EXPECT_EQ(kolmogorov_upper(0.0), 1.0);
  // the two series used below and above λ = 1 agree where they meet
  EXPECT_NEAR(kolmogorov_upper(std::nextafter(1.0, 0.0)), kolmogorov_upper(1.0), 1e-12);
}

// n1 = n2 = 100, b shifted by 20 of the common spacing: D = 0.2,
// λ = sqrt(100·100/200)·0.2 = sqrt(2), Q = 2(e^−4 − e^−16 + e^−36 ...) = 0.036631.
TEST(KolmogorovSmirnovTest, AsymptoticPByHand) {
  std::vector<double> a;
  std::vector<double> b;
  for (int i = 0; i < 100; ++i) {
    a.push_back(i);
    b.push_back(i + 20);
  }
  const KsResult r = ks_test(a, b);
  EXPECT_NEAR(r.d, 0.2, kExact);
  EXPECT_NEAR(r.p, 2.0 * (std::exp(-4.0) - std::exp(-16.0) + std::exp(-36.0)), 1e-12);
  EXPECT_EQ(r.n1, 100u);
  EXPECT_EQ(r.n2, 100u);
}

// The thesis' rule (1.4): D > 1.36·sqrt((n1+n2)/(n1·n2)) rejects at 5 %.
TEST(KolmogorovSmirnovTest, ThesisCriticalValueIsFivePercent) {
  const double lambda = 1.36;  // = sqrt(n1 n2/(n1+n2)) · D at the critical D
  EXPECT_NEAR(kolmogorov_upper(lambda), 0.05, 0.001);
}

// Exact p (n1·n2 < 10 000): under H0 each of the C(n1+n2, n1) assignments of
// the pooled values to the samples is equally likely. Disjoint samples reach
// D = 1 only by the two assignments "all of a first" and "all of b first".
TEST(KolmogorovSmirnovTest, ExactPOfDisjointSamplesIsTwoOverTheAssignments) {
  const KsResult r = ks_test(std::vector<double>{1, 2, 3}, std::vector<double>{4, 5, 6});
  EXPECT_TRUE(r.exact);
  EXPECT_NEAR(r.p, 2.0 / 20.0, 1e-15);  // C(6, 3) = 20
  // 2 / C(100, 50) = 1.98233e-29: the upper tail is summed from its own
  // paths, so a tiny p keeps its digits (1 − P(D < d) would give 0).
  std::vector<double> a;
  std::vector<double> b;
  for (int i = 0; i < 50; ++i) {
    a.push_back(i);
    b.push_back(i + 50);
  }
  EXPECT_NEAR(ks_exact_p(a, b) / (2.0 / 100891344545564193334812497256.0), 1.0, 1e-12);
}

// Ties, as R's psmirnov treats them: the gap counts only where the pooled
// value changes. a = {1, 1, 2}, b = {2, 3}: pooled 1 1 2 2 3, D = 2/3 (after
// the 1s). Of the C(5, 3) = 10 assignments, D >= 2/3 at a value change
// (after position 2 or 4) only when positions 1-2 are both a (3 ways) or
// both b (1 way): p = 4/10. Judging inside the run of 2s as well would count
// 6 of 10 (enumerated).
TEST(KolmogorovSmirnovTest, ExactPWithTiesByEnumeration) {
  const KsResult r = ks_test(std::vector<double>{1, 1, 2}, std::vector<double>{2, 3});
  EXPECT_NEAR(r.d, 2.0 / 3.0, kExact);
  EXPECT_NEAR(r.p, 0.4, 1e-15);
}

// Independent check against SciPy 1.10.1, scipy.stats.ks_2samp(a, b,
// method='exact') for a = 0..79, b = 20.5..118.5: D = 40/99,
// p = 5.345899461873255e-07.
TEST(KolmogorovSmirnovTest, ExactPMatchesScipy) {
  std::vector<double> a;
  std::vector<double> b;
  for (int i = 0; i < 80; ++i) a.push_back(i);
  for (int k = 0; k < 99; ++k) b.push_back(k + 20.5);
  const KsResult r = ks_test(a, b);
  EXPECT_TRUE(r.exact);
  EXPECT_NEAR(r.d, 40.0 / 99.0, kExact);
  EXPECT_NEAR(r.p / 5.345899461873255e-07, 1.0, 1e-12);
}

// R's rule: exact when n1·n2 < 10 000 (99·101 = 9999), asymptotic from
// 10 000 (AsymptoticPByHand above, 100·100).
TEST(KolmogorovSmirnovTest, ExactBelowTenThousandPairs) {
  const KsResult small = ks_test(std::vector<double>(99, 1.0), std::vector<double>(101, 2.0));
  EXPECT_TRUE(small.exact);
  const KsResult large = ks_test(std::vector<double>(100, 1.0), std::vector<double>(100, 2.0));
  EXPECT_FALSE(large.exact);
  EXPECT_EQ(large.p, large.p_asymptotic);
}

TEST(KolmogorovSmirnovTest, RejectsEmptySample) {
  EXPECT_THROW(ks_test(std::vector<double>{}, std::vector<double>{1}), DataError);
  EXPECT_THROW(ks_test(std::vector<double>{1, INFINITY}, std::vector<double>{1}), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
