// Issue 34 section 4, through the real binary (`hapticlab analyze` on
// study files built here, every force chosen): the report says what it
// computed. The participant-level section's sentence comes from m, alpha
// and n (it always said "fewer than 9 participants cannot reach that
// level"); the dose section bolds what the fixed-sequence procedure
// accepts, not each p below alpha; the medians say [Q1, Q3]; an empty
// participant-level cell has a null mean difference in the JSON.
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/settings/settings_json.h"
#include "db/study_db.h"
#include "tests/analysis/study/synthetic_study_db.h"
#include "tests/app/cli_process.h"
#include "tests/testing/files.h"
#include "tests/testing/scratch_dir.h"

namespace hapticlab::analysis {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

// The synthetic study's trial (tests/analysis/study/synthetic_study_db.h),
// the tip's path scaled with the force too.
void log_trial_of_force(db::StudyDb& db, std::int64_t trial, double f) {
  testing::log_trial_of_force(db, trial, f, f);
}

struct Setting {
  std::string name;
  std::string parameters_json = "{}";
};

// A study of `settings` (the first is the control) in which participant
// p (0-based) does setting s when force(p, s) is given (>= 0), once.
template <typename Force>
void build_study(const fs::path& path, const std::string& protocol_json, const std::vector<Setting>& settings,
                 int participants, Force force) {
  db::StudyDb db(path);
  const std::int64_t study = db.add_study({"statements", protocol_json, 7, "test"});
  std::vector<std::int64_t> ids;
  for (const Setting& s : settings) ids.push_back(db.add_setting_json(study, s.name, s.parameters_json));
  for (int p = 0; p < participants; ++p) {
    const std::int64_t pid = db.add_participant(study, "P" + std::to_string(p + 1));
    const std::int64_t session = db.begin_session(pid, "sim", "virtual", 1000.0);
    int position = 0;
    for (std::size_t s = 0; s < settings.size(); ++s) {
      const double f = force(p, static_cast<int>(s));
      if (f < 0) continue;
      const std::int64_t trial = db.add_trial({pid, "dissection", ids[s], 1, 1, ++position});
      db.start_trial(trial, session);
      log_trial_of_force(db, trial, f);
      db.end_trial(trial, db::TrialStatus::kComplete);
    }
    db.end_session(session);
  }
}

class ReportStatementsTest : public ::testing::Test {
 protected:
  // analyze --json; the report's Markdown in `markdown`.
  nlohmann::json analyze(const fs::path& db, std::string& markdown) {
    const fs::path out = dir_ / (db.stem().string() + "_report");
    const auto [rc, text] = hapticlab::testing::run_cli_stdout(
        HAPTICLAB_CLI_PATH, "analyze --db " + db.string() + " --out " + out.string() + " --no-plots --no-ks --json");
    EXPECT_EQ(rc, 0) << text;
    markdown = hapticlab::testing::slurp(out / "report.md");
    return nlohmann::json::parse(text);
  }
  hapticlab::testing::ScratchDir scratch_{"hapticlab_statements_"};
  const fs::path dir_ = scratch_.path();
};

// The sentence for 4 settings against the control with 8 participants
// (0.0078 < 0.01274: reachable, and reached, so bold) and for the thesis'
// case, 7 against the control with 3 participants (0.25: not even 0.05).
TEST_F(ReportStatementsTest, TheParticipantLevelSentenceIsComputedFromMAlphaAndN) {
  const fs::path four = dir_ / "four.db";
  build_study(four, R"({"study": "four"})",
              {{"High Fidelity"}, {"S1"}, {"S2"}, {"S3"}, {"S4"}}, 8,
              [](int p, int s) { return 1.0 + 0.125 * s + p / 64.0; });  // every setting above the control
  std::string md;
  (void)analyze(four, md);
  EXPECT_THAT(md, AllOf(HasSubstr("the level 0.01274 (alpha 0.05, m = 4 comparisons) needs at least 8 (2/2^8 = "
                                  "0.0078)"),
                        HasSubstr("In this task the comparisons have 8 participants (smallest p 0.0078), so one in "
                                  "which every participant differs in the same direction reaches it."),
                        HasSubstr("| S1 (8) | **0.0078"), Not(HasSubstr("fewer than 9"))));

  // Eight settings, three participants who did seven of them; a fourth did
  // only the eighth, so its comparison has no participant with both.
  const fs::path thesis = dir_ / "thesis.db";
  build_study(thesis, R"({"study": "thesis"})",
              {{"High Fidelity"}, {"S1"}, {"S2"}, {"S3"}, {"S4"}, {"S5"}, {"S6"}, {"Lonely"}}, 4,
              [](int p, int s) { return (p == 3) == (s == 7) ? 1.0 + 0.125 * s + p / 64.0 : -1.0; });
  const nlohmann::json j = analyze(thesis, md);
  EXPECT_THAT(md, AllOf(HasSubstr("(alpha 0.05, m = 7 comparisons) needs at least 9 (2/2^9 = 0.0039)"),
                        HasSubstr("In this task the comparisons have 3 participants (smallest p 0.25), so none can "
                                  "reach it, whatever the data."),
                        Not(HasSubstr("fewer than 9"))));
  // The medians are the quartiles, said so.
  EXPECT_THAT(md, AllOf(HasSubstr("Median [Q1, Q3] per setting"), Not(HasSubstr("interquartile range"))));
  // An empty cell has no mean difference, not 0.
  int empty = 0;
  for (const auto& c : j.at("participant_pairwise")) {
    if (c.at("setting") == "Lonely") {
      EXPECT_TRUE(c.at("p").is_null());
      EXPECT_TRUE(c.at("mean_difference").is_null()) << c.dump();
      ++empty;
    } else {
      EXPECT_TRUE(c.at("mean_difference").is_number()) << c.dump();
    }
  }
  EXPECT_EQ(empty, 5);  // one per measure
}

// The issue's case: 0.2 N significant against the control (p 0.031 with 6
// participants, all higher), the strongest not, so the fixed sequence stops
// at once and accepts nothing: nothing is bold, and the table says so.
TEST_F(ReportStatementsTest, TheDoseMediansBoldWhatTheFixedSequenceAccepts) {
  const std::string field = "translation.friction.dynamic_level_N";
  const NamedSettings base = settings_from_json(
      nlohmann::json::parse(R"({"name": "Insertion friction", "translation": {"friction": {}}})"), "test");
  const NamedSettings control = settings_from_json(nlohmann::json::parse(R"({"name": "High Fidelity"})"), "test");
  std::vector<Setting> settings = {{control.name, settings_to_json(control).dump()}};
  for (double x : {0.2, 0.5, 0.9}) {
    const NamedSettings s = settings_at_strength(base, field, x);
    settings.push_back({s.name, settings_to_json(s).dump()});
  }
  const fs::path db = dir_ / "dose.db";
  build_study(db,
              R"({"study": "dose", "dose": {"settings": {"name": "Insertion friction"}, "field": ")" + field +
                  R"(", "strengths": [0.2, 0.5, 0.9]}})",
              settings, 6, [](int p, int s) {
                const double own = 1.0 + p / 64.0;
                if (s == 0) return own;
                if (s == 1) return own + 0.125;                  // every participant higher: p = 2/2^6
                return own + (p % 2 == 0 ? 0.125 : -0.125);       // half higher, half lower: p = 1
              });
  std::string md;
  const nlohmann::json j = analyze(db, md);
  const nlohmann::json& rows = j.at("dose_response").at("rows");
  ASSERT_EQ(rows.size(), 5u);
  for (const auto& r : rows)
    if (r.at("measure") == "force_p95_N") {
      EXPECT_TRUE(r.at("smallest_significant_strength").is_null()) << r.dump();
    }
  EXPECT_THAT(md, HasSubstr("bold: the strengths the fixed-sequence procedure accepts"));
  EXPECT_THAT(md, HasSubstr("(p 0.031)"));  // 0.2 N against the control, unadjusted
  EXPECT_THAT(md, Not(HasSubstr("(p 0.031)**")));
  const std::size_t table = md.find("Median over participants of each participant's median");
  ASSERT_NE(table, std::string::npos);
  const std::string medians = md.substr(table, md.find("\n\n", md.find("|", table)) - table);
  EXPECT_THAT(medians, Not(HasSubstr("**"))) << medians;
}

}  // namespace
}  // namespace hapticlab::analysis
