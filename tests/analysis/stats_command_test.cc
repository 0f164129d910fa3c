#include "app/study/stats_command.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "analysis/stats/data_error.h"
#include "analysis/stats/testing_tables.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class StatsCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) / (std::string("stats_command_test_") + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write_file(const std::string& name, const std::string& text) const {
    const fs::path path = dir_ / name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  // RoundingTimes in long format: player,method,time
  fs::path rounding_csv() const {
    std::ostringstream csv;
    csv << "player,method,time\n";
    const char* methods[] = {"round_out", "narrow_angle", "wide_angle"};
    const auto rows = analysis::testing::rounding_times();
    for (std::size_t r = 0; r < rows.size(); ++r) {
      for (std::size_t m = 0; m < 3; ++m) csv << "P" << r + 1 << "," << methods[m] << "," << rows[r][m] << "\n";
    }
    return write_file("rounding.csv", csv.str());
  }

  // `hapticlab <args>`, in process, through CLI11; returns stdout.
  static std::string run(std::vector<std::string> args) {
    CLI::App app;
    add_stats_command(app);
    std::reverse(args.begin(), args.end());  // CLI11 2.1 takes the arguments last first
    ::testing::internal::CaptureStdout();
    try {
      app.parse(args);
    } catch (...) {
      ::testing::internal::GetCapturedStdout();
      throw;
    }
    return ::testing::internal::GetCapturedStdout();
  }

  fs::path dir_;
};

TEST_F(StatsCommandTest, FriedmanTable) {
  const std::string out = run({"stats", "friedman", "--csv", rounding_csv().string(), "--block",
                               "player", "--treatment", "method", "--value", "time"});
  EXPECT_THAT(out, HasSubstr("chi-square = 11.1429"));
  EXPECT_THAT(out, HasSubstr("df = 2"));
  EXPECT_THAT(out, HasSubstr("p = 0.00380"));
  EXPECT_THAT(out, HasSubstr("Kendall's W = 0.253"));
}

TEST_F(StatsCommandTest, FriedmanJson) {
  const auto j = nlohmann::json::parse(run({"stats", "friedman", "--csv", rounding_csv().string(),
                                            "--block", "player", "--treatment", "method",
                                            "--value", "time", "--json"}));
  EXPECT_NEAR(j.at("statistic").get<double>(), 11.143, 0.0005);
  EXPECT_EQ(j.at("df").get<double>(), 2.0);
  EXPECT_NEAR(j.at("p").get<double>(), 0.003805, 5e-7);
  EXPECT_EQ(j.at("n").get<int>(), 66);
  // Kendall's W = chi2 / (b (k - 1)) = 11.1429 / (22 * 2) = 0.2532, as R's
  // rstatix::friedman_effsize reports for RoundingTimes.
  EXPECT_NEAR(j.at("kendalls_w").get<double>(), 0.25325, 5e-5);
}

// Per-group results (thesis Table 3.4: one Friedman test per participant).
TEST_F(StatsCommandTest, FriedmanPerGroup) {
  std::ostringstream csv;
  csv << "surgeon,hand,setting,force\n";
  for (const char* s : {"S1", "S2"}) {
    for (const char* h : {"L", "R"}) {
      csv << s << "," << h << ",HiFi,1\n" << s << "," << h << ",NoFFB,3\n" << s << "," << h << ",AllDg,2\n";
    }
  }
  const auto j = nlohmann::json::parse(run({"stats", "friedman", "--csv",
                                            write_file("g.csv", csv.str()).string(), "--block",
                                            "hand", "--treatment", "setting", "--value", "force",
                                            "--group", "surgeon", "--json"}));
  ASSERT_EQ(j.at("groups").size(), 2u);
  EXPECT_EQ(j["groups"][1]["group"]["surgeon"], "S2");
  // 2 blocks, identical orderings: R = (2, 6, 4), Σ(R−4)² = 8, Q = 12·8/(2·3·4) = 4
  EXPECT_NEAR(j["groups"][0]["statistic"].get<double>(), 4.0, 1e-12);
}

// --method participant on a permutation worked by hand: three blocks, each
// with two repetitions per treatment. Block medians (matlab = mean of two):
// HiFi 1.5, 2.5, 1.5; A 3.5, 3.5, 1.0 -> differences +2, +1, -0.5. Of the
// 2^3 sign patterns, |sum| >= |2.5| for (+,+,+), (+,+,-), (-,-,+), (-,-,-):
// sums 3.5, 2.5, -2.5, -3.5, so p = 4/8 = 0.5; B is higher in every block
// by 1, 2, 3: only the all-plus and all-minus patterns reach |6|, p = 2/8.
TEST_F(StatsCommandTest, PairwiseByParticipantIsTheSignFlipPermutationWorkedByHand) {
  const auto path = write_file("s.csv",
                               "participant,setting,force\n"
                               "P1,HiFi,1\nP1,HiFi,2\nP1,A,3\nP1,A,4\nP1,B,2\nP1,B,3\n"
                               "P2,HiFi,2\nP2,HiFi,3\nP2,A,3\nP2,A,4\nP2,B,4\nP2,B,5\n"
                               "P3,HiFi,1\nP3,HiFi,2\nP3,A,0.5\nP3,A,1.5\nP3,B,4\nP3,B,5\n");
  const auto j = nlohmann::json::parse(run({"stats", "pairwise", "--method", "participant", "--csv", path.string(),
                                            "--block", "participant", "--treatment", "setting", "--value",
                                            "force", "--control", "HiFi", "--json"}));
  EXPECT_EQ(j.at("test"), "pairwise-sign-flip");
  EXPECT_EQ(j.at("m").get<int>(), 2);
  ASSERT_EQ(j.at("comparisons").size(), 2u);
  EXPECT_EQ(j["comparisons"][0]["treatment"], "A");
  EXPECT_EQ(j["comparisons"][0]["n_blocks"].get<int>(), 3);
  EXPECT_DOUBLE_EQ(j["comparisons"][0]["p"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(j["comparisons"][0]["mean_difference"].get<double>(), 2.5 / 3.0);
  EXPECT_DOUBLE_EQ(j["comparisons"][1]["p"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(j["comparisons"][1]["mean_difference"].get<double>(), 2.0);
  EXPECT_FALSE(j["comparisons"][1]["significant"].get<bool>());  // 0.25 > the Sidak level 0.0253
  const std::string table = run({"stats", "pairwise", "--method", "participant", "--csv", path.string(), "--block",
                                 "participant", "--treatment", "setting", "--value", "force", "--control", "HiFi"});
  EXPECT_THAT(table, HasSubstr("smallest p is 2/2^n"));
}

TEST_F(StatsCommandTest, PairwiseJsonHasNullForNoData) {
  const auto path = write_file("p.csv",
                               "b,t,v\n"
                               "1,HiFi,1\n1,NoFFB,2\n"
                               "2,HiFi,1\n2,NoFFB,3\n"
                               "3,HiFi,2\n3,Sat,1\n");
  const auto j = nlohmann::json::parse(run({"stats", "pairwise", "--csv", path.string(), "--block",
                                            "b", "--treatment", "t", "--value", "v", "--control",
                                            "HiFi", "--json"}));
  EXPECT_EQ(j.at("m").get<int>(), 2);
  EXPECT_NEAR(j.at("sidak_level").get<double>(), 1.0 - std::sqrt(0.95), 1e-12);
  ASSERT_EQ(j.at("comparisons").size(), 2u);
  EXPECT_EQ(j["comparisons"][0]["treatment"], "NoFFB");
  EXPECT_EQ(j["comparisons"][0]["n_blocks"].get<int>(), 2);
  // 2 blocks, HiFi < NoFFB in both: rank sums 2 and 4, statistic
  // 12/(2·2·3)·(2² + 4²) − 3·2·3 = 2 on 1 df, from 4 values.
  EXPECT_NEAR(j["comparisons"][0]["statistic"].get<double>(), 2.0, 1e-12);
  EXPECT_EQ(j["comparisons"][0]["df"].get<double>(), 1.0);
  EXPECT_EQ(j["comparisons"][0]["n"].get<int>(), 4);
  EXPECT_EQ(j["comparisons"][1]["n_blocks"].get<int>(), 1);

  const auto k = nlohmann::json::parse(
      run({"stats", "pairwise", "--csv", write_file("q.csv", "b,t,v\n1,HiFi,1\n1,A,2\n2,HiFi,1\n2,A,2\n3,B,4\n3,C,5\n").string(),
           "--block", "b", "--treatment", "t", "--value", "v", "--control", "HiFi", "--json"}));
  EXPECT_TRUE(k["comparisons"][1]["p"].is_null());
  EXPECT_TRUE(k["comparisons"][1]["df"].is_null());
  EXPECT_EQ(k["comparisons"][1]["n"].get<int>(), 0);
  EXPECT_EQ(k["comparisons"][1]["n_blocks"].get<int>(), 0);
}

TEST_F(StatsCommandTest, PairwiseTablePrintsNA) {
  const auto path = write_file("q.csv", "b,t,v\n1,HiFi,1\n1,A,2\n2,HiFi,1\n2,A,2\n3,B,4\n3,C,5\n");
  const std::string out = run({"stats", "pairwise", "--csv", path.string(), "--block", "b",
                               "--treatment", "t", "--value", "v", "--control", "HiFi"});
  EXPECT_THAT(out, HasSubstr("N/A"));
  EXPECT_THAT(out, HasSubstr("Sidak"));
}

TEST_F(StatsCommandTest, CorrelationWithGroups) {
  std::ostringstream csv;
  csv << "hand,trial,force\n";
  for (int i = 1; i <= 5; ++i) csv << "L," << i << "," << 2 * i << "\n";
  for (int i = 1; i <= 5; ++i) csv << "R," << i << "," << (i % 2) << "\n";
  const auto j = nlohmann::json::parse(run({"stats", "correlation", "--csv",
                                            write_file("c.csv", csv.str()).string(), "--x",
                                            "trial", "--y", "force", "--group", "hand", "--json"}));
  ASSERT_EQ(j.at("groups").size(), 2u);
  EXPECT_NEAR(j["groups"][0]["r"].get<double>(), 1.0, 1e-12);
  EXPECT_EQ(j["groups"][0]["strength"], "strong");
  EXPECT_EQ(j["groups"][1]["n"].get<int>(), 5);
}

TEST_F(StatsCommandTest, KsWithBootstrapIsReproducible) {
  std::ostringstream csv;
  csv << "surgeon,setting,rep,force\n";
  for (const char* s : {"S1", "S2"}) {
    for (int rep = 1; rep <= 3; ++rep) {
      for (int i = 0; i < 50; ++i) csv << s << ",HiFi," << rep << "," << (i * 7 + rep) % 13 << "\n";
      for (int i = 0; i < 50; ++i) csv << s << ",NoFFB," << rep << "," << 20 + (i * 5 + rep) % 11 << "\n";
    }
  }
  const auto path = write_file("ks.csv", csv.str());
  const std::vector<std::string> args = {"stats", "ks", "--csv", path.string(), "--block",
                                         "surgeon", "--treatment", "setting", "--replicate", "rep",
                                         "--value", "force", "--control", "HiFi", "--other",
                                         "NoFFB", "--bootstrap", "100", "--block-length", "5",
                                         "--seed", "3", "--json"};
  const auto first = nlohmann::json::parse(run(args));
  const auto second = nlohmann::json::parse(run(args));
  EXPECT_EQ(first, second);
  EXPECT_EQ(first.at("statistic").get<double>(), 1.0);
  EXPECT_TRUE(first["bootstrap"]["significant"].get<bool>());
  EXPECT_EQ(first["bootstrap"]["participants_used"].get<int>(), 2);
}

// With --replicate a repeated (block, treatment, replicate) was ranked as one
// more replicate: a file pasted onto itself doubled its chi-square's
// evidence. The block tests now refuse it, naming both lines; without
// --replicate, rows of one cell are replicates in file order, as documented.
TEST_F(StatsCommandTest, ARepeatedReplicateIsRefusedByTheBlockTests) {
  std::string rows;
  for (const char* s : {"S1", "S2", "S3"})
    for (int rep = 1; rep <= 2; ++rep)
      for (const char* t : {"A", "B", "C"})
        rows += std::string(s) + "," + t + "," + std::to_string(rep) + "," +
                std::to_string((t[0] - 'A') * 3 + rep + (s[1] - '0')) + "\n";
  const auto once = write_file("once.csv", "s,t,rep,v\n" + rows);
  const auto twice = write_file("twice.csv", "s,t,rep,v\n" + rows + rows);
  const std::vector<std::string> options = {"--block", "s", "--treatment", "t", "--replicate", "rep", "--value", "v"};
  // (durbin takes one observation per cell and says so.)
  for (const std::vector<std::string>& command :
       {std::vector<std::string>{"stats", "friedman"}, {"stats", "pairwise", "--control", "A"},
        {"stats", "pairwise", "--control", "A", "--method", "participant"}}) {
    std::vector<std::string> args = command;
    args.insert(args.end(), {"--csv", once.string()});
    args.insert(args.end(), options.begin(), options.end());
    EXPECT_NO_THROW(run(args)) << command[1];
    args[command.size() + 1] = twice.string();
    try {
      run(args);
      ADD_FAILURE() << command[1] << " took the repeated rows";
    } catch (const analysis::DataError& e) {
      EXPECT_THAT(e.what(), HasSubstr("lines 2 and 20 are both block 'S1', treatment 'A', replicate '1' "
                                      "(--replicate rep)")) << command[1];
    }
  }
  // Without --replicate the same file is read as four replicates per cell.
  EXPECT_NO_THROW(run({"stats", "friedman", "--csv", twice.string(), "--block", "s", "--treatment", "t", "--value",
                       "v"}));
}

TEST_F(StatsCommandTest, KsBootstrapNeedsReplicateColumn) {
  const auto path = write_file("k.csv", "s,t,v\nS1,A,1\nS1,B,2\n");
  // A treatment against itself was reported as an empty sample of the other.
  try {
    run({"stats", "ks", "--csv", path.string(), "--block", "s", "--treatment", "t", "--value", "v", "--control", "A",
         "--other", "A"});
    ADD_FAILURE() << "ks took --other equal to --control";
  } catch (const analysis::DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--control and --other are both 'A'"));
  }
  EXPECT_THROW(run({"stats", "ks", "--csv", path.string(), "--block", "s", "--treatment", "t",
                    "--value", "v", "--control", "A", "--other", "B", "--bootstrap", "100",
                    "--block-length", "1"}),
               analysis::DataError);
}

// One repetition of T missing in block 2 used to fail every comparison
// ("unequal replicates"); now balanced as the study analysis does. Kept: 2
// per cell in all 3 blocks (12 of 16 values), C below T in each: Q = 7.2
// (see PairwiseFriedmanTest.UnequalRepetitionsAreBalanced).
TEST_F(StatsCommandTest, PairwiseBalancesUnequalRepetitionsAndSaysWhatWasDropped) {
  const auto path = write_file("u.csv",
                               "b,t,v\n"
                               "B1,C,1\nB1,C,2\nB1,C,3\nB1,T,4\nB1,T,5\nB1,T,6\n"
                               "B2,C,1\nB2,C,2\nB2,C,3\nB2,T,4\nB2,T,5\n"
                               "B3,C,1\nB3,C,2\nB3,T,3\nB3,T,4\nB3,T,5\n");
  const std::vector<std::string> args = {"stats", "pairwise", "--csv", path.string(), "--block",
                                         "b", "--treatment", "t", "--value", "v", "--control", "C"};
  const std::string out = run(args);
  EXPECT_THAT(out, HasSubstr("7.2"));
  EXPECT_THAT(out, HasSubstr("T: balanced to 2 repetition(s) per cell: 4 observation(s) dropped"));
  std::vector<std::string> json_args = args;
  json_args.push_back("--json");
  const auto j = nlohmann::json::parse(run(json_args));
  const auto& c = j.at("comparisons").at(0);
  EXPECT_NEAR(c.at("statistic").get<double>(), 7.2, 1e-12);
  EXPECT_EQ(c.at("replicates").get<int>(), 2);
  EXPECT_EQ(c.at("dropped_observations").get<int>(), 4);
  EXPECT_EQ(c.at("blocks_left_out").get<int>(), 0);
}

// A pooled two-sample test needs no block column. {1, 2, 3} vs {4, 5, 6}:
// D = 1, exact p = 2/C(6, 3) = 0.1 (the asymptotic p would be
// Q(sqrt(3·3/6)) = 2(e^−3 − e^−12 + e^−27 ...) = 0.0996).
TEST_F(StatsCommandTest, KsPooledNeedsNoBlockAndReportsTheExactP) {
  const auto path = write_file("k.csv", "setting,force\nA,1\nA,2\nA,3\nB,4\nB,5\nB,6\n");
  const std::vector<std::string> args = {"stats", "ks", "--csv", path.string(), "--treatment",
                                         "setting", "--value", "force", "--control", "A",
                                         "--other", "B"};
  EXPECT_THAT(run(args), HasSubstr("D = 1, exact p = 0.1\n"));
  std::vector<std::string> json_args = args;
  json_args.push_back("--json");
  const auto j = nlohmann::json::parse(run(json_args));
  EXPECT_EQ(j.at("p_method"), "exact");
  EXPECT_NEAR(j.at("p").get<double>(), 0.1, 1e-15);
  EXPECT_NEAR(j.at("p_asymptotic").get<double>(),
              2.0 * (std::exp(-3.0) - std::exp(-12.0) + std::exp(-27.0)), 1e-12);
  // The bootstrap resamples per participant, so it does need the column.
  json_args.insert(json_args.end(), {"--bootstrap", "100", "--block-length", "1", "--replicate",
                                     "setting"});
  try {
    run(json_args);
    FAIL() << "expected DataError";
  } catch (const analysis::DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--block"));
  }
}

// A header and no rows used to print nothing and exit 0.
TEST_F(StatsCommandTest, HeaderOnlyCsvIsRefused) {
  const auto path = write_file("h.csv", "block,treatment,value,x,y\n");
  const std::vector<std::vector<std::string>> commands = {
      {"stats", "correlation", "--csv", path.string(), "--x", "x", "--y", "y"},
      {"stats", "friedman", "--csv", path.string()},
      {"stats", "pairwise", "--csv", path.string(), "--control", "A"},
      {"stats", "durbin", "--csv", path.string()},
      {"stats", "skillings-mack", "--csv", path.string()},
      {"stats", "ks", "--csv", path.string(), "--control", "A", "--other", "B"}};
  for (const auto& args : commands) {
    try {
      run(args);
      ADD_FAILURE() << args[1] << ": expected DataError";
    } catch (const analysis::DataError& e) {
      EXPECT_THAT(e.what(), HasSubstr("no data rows")) << args[1];
      EXPECT_THAT(e.what(), HasSubstr("h.csv")) << args[1];
    }
  }
}

TEST_F(StatsCommandTest, CorrelationOfAConstantColumnNamesIt) {
  const auto path = write_file("c.csv", "trial,force\n1,0.1\n2,0.1\n3,0.1\n");
  try {
    run({"stats", "correlation", "--csv", path.string(), "--x", "trial", "--y", "force"});
    FAIL() << "expected DataError";
  } catch (const analysis::DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("force is constant"));
  }
}

TEST_F(StatsCommandTest, ErrorsAreRuntimeErrorsNamingTheProblem) {
  const auto path = rounding_csv();
  try {
    run({"stats", "friedman", "--csv", path.string(), "--block", "player", "--treatment",
         "method"});  // default value column "value" is absent
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("'value'"));
    EXPECT_THAT(e.what(), HasSubstr("player, method, time"));
  }
  EXPECT_THROW(run({"stats", "friedman"}), CLI::RequiredError);
}

TEST_F(StatsCommandTest, HelpDocumentsEveryOption) {
  CLI::App app;
  add_stats_command(app);
  CLI::App* ks = app.get_subcommand("stats")->get_subcommand("ks");
  const std::string help = ks->help();
  for (const char* option : {"--csv", "--block", "--treatment", "--replicate", "--value", "--json",
                             "--group", "--control", "--other", "--bootstrap", "--block-length",
                             "--seed", "--percentile-method"}) {
    EXPECT_THAT(help, HasSubstr(option));
  }
  for (const auto* sub : app.get_subcommand("stats")->get_subcommands({})) {
    for (const auto* opt : sub->get_options()) {
      if (opt->get_name() == "--help") continue;
      EXPECT_FALSE(opt->get_description().empty()) << sub->get_name() << " " << opt->get_name();
    }
  }
}

}  // namespace
}  // namespace hapticlab::app
