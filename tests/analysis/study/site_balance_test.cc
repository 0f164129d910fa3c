// Sites against settings in a merged multi-site study (site_balance.h):
// the definitions of docs/analysis.md, "Multi-site studies", on small
// hand-made designs.
#include "analysis/study/site_balance.h"

#include <map>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "analysis/study/study_analysis.h"

namespace hapticlab::analysis {
namespace {

using ::testing::HasSubstr;

// One analysed trial per (participant, setting) given.
std::vector<TrialRecord> trials(const std::vector<std::pair<std::string, std::string>>& done) {
  std::vector<TrialRecord> out;
  for (const auto& [who, setting] : done) {
    TrialRecord t;
    t.participant = who;
    t.task = "clip";
    t.setting = setting;
    out.push_back(t);
  }
  return out;
}

const std::vector<std::string> kSettings = {"HF", "Friction", "Inertia"};

TEST(SiteBalance, ACompleteDesignIsBalanced) {
  const std::map<std::string, std::string> sites = {{"A1", "a"}, {"B1", "b"}, {"B2", "b"}};
  std::vector<std::pair<std::string, std::string>> done;
  for (const char* who : {"A1", "B1", "B2"})
    for (const std::string& s : kSettings) done.emplace_back(who, s);
  const auto b = site_balance(trials(done), sites, {"clip"}, kSettings);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_TRUE(b[0].balanced()) << b[0].verdict();
  EXPECT_EQ(b[0].sites, (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(b[0].participants, (std::vector<int>{1, 2}));
  EXPECT_EQ(b[0].counts, (std::vector<std::vector<int>>{{1, 1, 1}, {2, 2, 2}}));
  EXPECT_THAT(b[0].verdict(), HasSubstr("balanced: every site ran every setting"));
}

TEST(SiteBalance, ASettingAtOneSiteOnlyIsConfoundedWithIt) {
  const std::map<std::string, std::string> sites = {{"A1", "a"}, {"B1", "b"}};
  const auto b = site_balance(trials({{"A1", "HF"}, {"A1", "Inertia"}, {"B1", "HF"}, {"B1", "Friction"}}), sites,
                              {"clip"}, kSettings);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_FALSE(b[0].balanced());
  EXPECT_EQ(b[0].confounded,
            (std::vector<std::pair<std::string, std::string>>{{"Friction", "b"}, {"Inertia", "a"}}));
  EXPECT_THAT(b[0].verdict(), HasSubstr("confounded: 'Friction' only at site 'b'; 'Inertia' only at site 'a'"));
}

TEST(SiteBalance, UnequalSharesAreUnbalancedAndOneSiteHasNothingToConfound) {
  // Site b: 1 of 2 participants ran Friction; site a: its 1 of 1.
  const std::map<std::string, std::string> sites = {{"A1", "a"}, {"B1", "b"}, {"B2", "b"}};
  const auto b = site_balance(
      trials({{"A1", "HF"}, {"A1", "Friction"}, {"B1", "HF"}, {"B1", "Friction"}, {"B2", "HF"}}), sites, {"clip"},
      kSettings);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_TRUE(b[0].confounded.empty());
  EXPECT_EQ(b[0].unbalanced, std::vector<std::string>{"Friction"});
  EXPECT_THAT(b[0].verdict(), HasSubstr("unbalanced: the sites ran 'Friction' with different shares"));
  // All at one site: no table.
  EXPECT_TRUE(site_balance(trials({{"B1", "HF"}, {"B2", "Friction"}}), sites, {"clip"}, kSettings).empty());
}

}  // namespace
}  // namespace hapticlab::analysis
