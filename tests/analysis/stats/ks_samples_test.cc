// The samples of stats ks (analysis/stats/ks_samples.h), without the CLI:
// both treatments pooled in row order, each participant's repetitions as
// series (the bootstrap's input), other treatments and other rows left out,
// and a treatment with no row refused by name.
#include "analysis/stats/ks_samples.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/stats/data_error.h"

namespace hapticlab::analysis {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::vector<Observation> ks_rows() {
  return {{"P1", "HF", "r1", 1.0}, {"P1", "HF", "r1", 2.0}, {"P1", "NFF", "r1", 10.0}, {"P1", "HF", "r2", 3.0},
          {"P2", "NFF", "r1", 20.0}, {"P1", "Other", "r1", 99.0}, {"P2", "HF", "r1", 4.0}, {"P1", "NFF", "r1", 11.0},
          {"P3", "HF", "r1", 50.0}};
}

TEST(KsSamplesTest, PoolsBothTreatmentsAndGroupsEachParticipantsRepetitionsIntoSeries) {
  // Row 8 (P3) is not among the rows asked for (another group's).
  const KsSamples s = gather_ks_samples(ks_rows(), {0, 1, 2, 3, 4, 5, 6, 7}, "HF", "NFF", "data.csv", "setting");
  EXPECT_THAT(s.control, ElementsAre(1.0, 2.0, 3.0, 4.0));
  EXPECT_THAT(s.other, ElementsAre(10.0, 20.0, 11.0));
  ASSERT_EQ(s.participants.size(), 2u);
  EXPECT_EQ(s.participants[0].participant, "P1");
  EXPECT_THAT(s.participants[0].control, ElementsAre(ElementsAre(1.0, 2.0), ElementsAre(3.0)));
  EXPECT_THAT(s.participants[0].other, ElementsAre(ElementsAre(10.0, 11.0)));
  EXPECT_EQ(s.participants[1].participant, "P2");
  EXPECT_THAT(s.participants[1].control, ElementsAre(ElementsAre(4.0)));
  EXPECT_THAT(s.participants[1].other, ElementsAre(ElementsAre(20.0)));
}

TEST(KsSamplesTest, ATreatmentWithoutRowsIsRefusedByName) {
  try {
    (void)gather_ks_samples(ks_rows(), {0, 1, 3, 6}, "HF", "NFF", "data.csv", "setting");
    FAIL() << "no NFF row, but no refusal";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("data.csv: no rows with setting = 'NFF'"));
  }
  EXPECT_THROW((void)gather_ks_samples(ks_rows(), {2, 4}, "HF", "NFF", "data.csv", "setting"), DataError);
}

}  // namespace
}  // namespace hapticlab::analysis
