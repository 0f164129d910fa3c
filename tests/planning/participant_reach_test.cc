// participant_power_note (planning/participant_reach.h), numbers by hand:
// with m = 4 comparisons at alpha 0.05 the Šidák level is
// 1 - 0.95^(1/4) = 0.01274; the sign-flip test's smallest p with n
// participants is 2/2^n: 0.25 with 3, 0.0156 with 7 (still above), 0.0078
// with 8 (below), so 8 are needed. With m = 7 the level is 0.007301 and 8
// are not enough (0.0078): 9 are.
#include "planning/participant_reach.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace hapticlab::planning {
namespace {

using ::testing::HasSubstr;

TEST(ParticipantReachTest, PowerThatIsZeroByConstructionIsSaidSoWithTheParticipantsNeeded) {
  EXPECT_EQ(participant_power_note(3, 0.05, 4),
            "participant-level power is 0 by construction with 3 participants: the sign-flip test's smallest p, "
            "2/2^3 = 0.25, is not below the Šidák level 0.01274 (alpha 0.05, m = 4 comparisons); it needs at "
            "least 8 participants");
  EXPECT_THAT(participant_power_note(7, 0.05, 4), HasSubstr("2/2^7 = 0.016, is not below the Šidák level 0.01274"));
  EXPECT_EQ(participant_power_note(8, 0.05, 4), "");
  EXPECT_THAT(participant_power_note(8, 0.05, 7), HasSubstr("level 0.007301 (alpha 0.05, m = 7 comparisons); it "
                                                            "needs at least 9 participants"));
  EXPECT_EQ(participant_power_note(9, 0.05, 7), "");
  // One comparison: the level is alpha; 2/2^5 = 0.0625 is not below it, 2/2^6 = 0.031 is.
  EXPECT_THAT(participant_power_note(1, 0.05, 1),
              HasSubstr("with 1 participant: the sign-flip test's smallest p, 2/2^1 = 1, is not below the Šidák "
                        "level 0.05 (alpha 0.05, m = 1 comparison); it needs at least 6 participants"));
  EXPECT_EQ(participant_power_note(6, 0.05, 1), "");
}

}  // namespace
}  // namespace hapticlab::planning
