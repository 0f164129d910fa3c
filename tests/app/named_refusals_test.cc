// Issue 34 section 3, through the real binary: messages that said
// "stoull", "At Most 1 required but received 2", a 309-digit number, "1
// required TEXT missing" or "does not start with SQLite format 3" now name
// the option or field, the value and what is allowed; a damaged row names
// the file and the row; plan calibrate checks --out before it simulates;
// setting names are unique ignoring case and spaces; a staircase with an
// external VE is refused.
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/app/cli_process.h"
#include "tests/testing/sqlite_edit.h"
#include "tests/testing/scratch_dir.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

const fs::path kSettings = fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "settings";

class NamedRefusalsTest : public ::testing::Test {
 protected:
  static std::pair<int, std::string> cli(const std::string& args) { return testing::run_cli(HAPTICLAB_CLI_PATH, args); }
  // A protocol of `settings` (JSON array items) for 2 participants, one clip repetition.
  fs::path protocol(const std::string& name, const std::string& settings, const std::string& extra = "") const {
    const fs::path p = dir_ / name;
    std::ofstream(p) << R"({"study": "named", "tasks": ["clip"], "repetitions": {"clip": 1}, "settings": [)"
                     << settings << R"(], "participants": ["A", "B"], "design": {"type": "complete"}, "seed": 5)"
                     << extra << "}";
    return p;
  }
  std::string two_settings() const {
    return "\"" + (kSettings / "high_fidelity.json").string() + "\", \"" +
           (kSettings / "no_force_feedback.json").string() + "\"";
  }
  hapticlab::testing::ScratchDir scratch_{"hapticlab_named_"};
  const fs::path dir_ = scratch_.path();
};

void edit_study_db(const fs::path& db, const std::string& sql) { testing::edit_with_sqlite(db, sql); }

// A trial that reaches --max-trial-s is aborted for good, so a slip such
// as 1e-300 would have ruined the design: every command that runs designed
// trials takes 1..3600 s, as plan calibrate did. --max-trials is a count:
// a whole number, its range named (1.5 gave CLI11's "Could not convert").
TEST_F(NamedRefusalsTest, TrialLimitsAndTrialCountsAreNamedWithTheirRange) {
  const std::string session = "session run --db " + (dir_ / "none.db").string() + " --participant A ";
  const std::string plan = "plan power --protocol " + protocol("p.json", two_settings()).string() +
                           " --studies 1 --no-plots --out " + (dir_ / "plan").string() + " ";
  const std::string calibrate = "plan calibrate --protocol " + protocol("c.json", two_settings()).string() +
                                " --out " + (dir_ / "cal").string() + " ";
  for (const std::string& command : {session, plan, calibrate}) {
    for (const char* value : {"1e-300", "0.5", "3601"}) {
      const auto [rc, text] = cli(command + "--max-trial-s " + value);
      EXPECT_EQ(rc, 2) << command;
      EXPECT_THAT(text, HasSubstr("--max-trial-s: '" + std::string(value) +
                                  "' is refused: must be a finite number from 1 to 3600"))
          << command;
    }
  }
  for (const char* value : {"1.5", "-1", "1000001"}) {
    const auto [rc, text] = cli(session + "--max-trials " + value);
    EXPECT_EQ(rc, 2);
    EXPECT_THAT(text, AllOf(HasSubstr("--max-trials: '" + std::string(value) +
                                      "' is refused: must be a whole number from 0 to 1000000"),
                            Not(HasSubstr("Could not convert"))));
  }
  EXPECT_FALSE(fs::exists(dir_ / "none.db"));
  EXPECT_FALSE(fs::exists(dir_ / "plan"));
}

TEST_F(NamedRefusalsTest, OptionValuesAreNamedWithWhatIsAllowed) {
  // --studies 1 and an --out of its own: had a value slipped through, the run would be short and kept here.
  const std::string plan = "plan power --protocol " + protocol("p.json", two_settings()).string() +
                           " --studies 1 --no-plots --out " + (dir_ / "plan").string() + " ";
  auto [rc, text] = cli(plan + "--seed -1");
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, HasSubstr("--seed: '-1' is refused: must be a whole number from 0 to 18446744073709551615"));
  std::tie(rc, text) = cli(plan + "--seed 99999999999999999999");  // strtoull saturated it before
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, HasSubstr("--seed: '99999999999999999999' is refused"));
  std::tie(rc, text) = cli(plan + "--seed 1 --seed 2");
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, AllOf(HasSubstr("--seed is given 2 values ('1', '2'), but takes one"), Not(HasSubstr("At Most"))));
  std::tie(rc, text) = cli(plan + "--max-trial-s inf");
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, AllOf(HasSubstr("--max-trial-s: 'inf' is refused: must be a finite number from 1 to 3600"),
                          Not(HasSubstr("17976931348623157"))));
  std::tie(rc, text) = cli(plan + "--rate-hz nan");  // passed CLI::Range before
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, HasSubstr("--rate-hz: 'nan' is refused: must be a finite number from 150 to 2000"));
  std::tie(rc, text) = cli(plan + "--participants 2,,3");
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, HasSubstr("--participants: '2,,3' is refused: an empty item in the comma-separated list"));
  std::tie(rc, text) = cli("stability map --effects , --out " + (dir_ / "map").string());
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, AllOf(HasSubstr("--effects: ',' is refused: an empty item in the comma-separated list"),
                          Not(HasSubstr("required TEXT missing")), Not(HasSubstr("'--out'"))));
  EXPECT_FALSE(fs::exists(dir_ / "map"));
  std::tie(rc, text) = cli("sim run --settings " + (kSettings / "high_fidelity.json").string() + " --trial-seed -1 --out " +
                           (dir_ / "s.db").string());
  EXPECT_EQ(rc, 2);
  EXPECT_THAT(text, HasSubstr("--trial-seed: '-1' is refused"));
  EXPECT_FALSE(fs::exists(dir_ / "s.db"));
}

// Damaged copies of a study file, made through SQLite: each refusal names
// the file, the row and what the column may hold.
TEST_F(NamedRefusalsTest, ADamagedStudyFileNamesTheFileTheRowAndTheValue) {
  const fs::path good = dir_ / "good.db";
  auto [rc, text] = cli("study create --protocol " + protocol("p.json", two_settings()).string() + " --db " + good.string());
  ASSERT_EQ(rc, 0) << text;
  const auto damaged = [&](const std::string& name, const std::string& sql) {
    const fs::path copy = dir_ / name;
    fs::copy_file(good, copy);
    edit_study_db(copy, sql);
    return copy;
  };
  const std::string analyze = " --no-plots --no-ks --quiet --out " + (dir_ / "report").string();
  fs::path db = damaged("seed.db", "UPDATE study SET seed = 'x12'");
  std::tie(rc, text) = cli("analyze --db " + db.string() + analyze);
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr(db.string() + ": study 1: column study.seed is 'x12', but must be a whole "
                                    "number from 0 to 18446744073709551615"),
                          Not(HasSubstr("stoull"))));
  db = damaged("status.db", "PRAGMA ignore_check_constraints = ON; UPDATE trial SET status = 'exploded' WHERE id = 2");
  std::tie(rc, text) = cli("analyze --db " + db.string() + analyze);
  EXPECT_EQ(rc, 1);
  // Found with the structure, at open (the schema's CHECKs, value_rules.h).
  EXPECT_THAT(text, HasSubstr(db.string() + ": the file's structure is damaged, 1 finding(s); trial 2: status is "
                                            "'exploded', which breaks CHECK (status IN ('planned', 'running', "
                                            "'complete', 'aborted'))"));
  // A page size of 768 (bytes 16-17): SQLite format 3 all the same.
  db = dir_ / "page.db";
  fs::copy_file(good, db);
  {
    std::fstream f(db, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(16);
    f.put('\x03').put('\x00');
  }
  std::tie(rc, text) = cli("analyze --db " + db.string() + analyze);
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr(db.string() + ": an SQLite file with a damaged header: its page size (bytes "
                                                  "16-17) is 768, but must be a power of two from 512 to 32768"),
                          Not(HasSubstr("does not start with"))));
  // And a file that is not SQLite still says so.
  db = dir_ / "text.db";
  std::ofstream(db) << "hello, this is not a database at all, but long enough to be read as a header..........";
  std::tie(rc, text) = cli("analyze --db " + db.string() + analyze);
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, HasSubstr("does not start with \"SQLite format 3\""));
}

// plan calibrate found an --out it could not write only after simulating
// every participant.
TEST_F(NamedRefusalsTest, PlanCalibrateChecksItsOutputFolderBeforeSimulating) {
  std::ofstream(dir_ / "a_file") << "x";
  const fs::path out = dir_ / "a_file" / "calibration";
  const auto [rc, text] = cli("plan calibrate --protocol " + protocol("p.json", two_settings()).string() +
                              " --participants 2 --rate-hz 250 --out " + out.string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr("--out '" + out.string() + "': cannot make the folder"),
                          HasSubstr("nothing was simulated"), Not(HasSubstr("simulating"))));
}

// Every command that writes a folder names an --out it cannot use before
// its work (an outside check found the library's "filesystem error: cannot
// create directories: Not a directory [afile]" from several).
TEST_F(NamedRefusalsTest, AnOutThatIsAFileIsNamedByEveryCommandThatWritesAFolder) {
  const fs::path file = dir_ / "a_file";
  std::ofstream(file) << "x";
  std::ofstream(dir_ / "trials.csv") << "participant,group,phase,trial,completion_time_s\n"
                                        "A,g,training,1,30\nA,g,training,2,25\nA,g,training,3,22\nA,g,training,4,20\n"
                                        "A,g,training,5,19\nA,g,training,6,18\n";
  const std::string protocols = std::string(HAPTICLAB_SOURCE_DIR) + "/examples/protocols/";
  for (const auto& [args, not_done] : std::vector<std::pair<std::string, std::string>>{
           {"demo --quick", "nothing was simulated"},
           {"plan calibrate --fit --fit-studies 1", "nothing was simulated"},
           {"plan power --studies 1 --no-plots --protocol " + protocols + "transfer_pilot.json", "nothing was simulated"},
           {"stats learning " + (dir_ / "trials.csv").string() + " --no-figures", "nothing was written"}}) {
    const auto [rc, text] = cli(args + " --out " + file.string());
    EXPECT_EQ(rc, 1) << args;
    EXPECT_THAT(text, HasSubstr("--out '" + file.string() + "': exists and is not a folder; " + not_done)) << args;
  }
}

// From an outside check of the simulated rig's commands: a recording in
// milliseconds replayed without end (2.5 GB in 30 s); `sim run --out` onto
// its --population file replaced the population by the trial's CSV;
// /dev/zero as the population grew without limit; an empty --population
// (an unset script variable) used the default without a word.
TEST_F(NamedRefusalsTest, SimInputsThatWouldRunWithoutEndOrBeLostAreRefused) {
  const fs::path csv = dir_ / "ms.csv";
  std::ofstream(csv) << "t_s,instrument,insertion_m,pitch_rad,yaw_rad,ve_force_x_N,ve_force_y_N,ve_force_z_N\n"
                        "0,0,0.1,0,0,0,0,0\n0,1,0.1,0,0,0,0,0\n1e6,0,0.1,0,0,0,0,0\n1e6,1,0.1,0,0,0,0,0\n";
  const std::string hf = (kSettings / "high_fidelity.json").string();
  auto [rc, text] = cli("sim replay --csv " + csv.string() + " --task clip --settings " + hf + " --out " +
                        (dir_ / "replay.csv").string());
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, HasSubstr("the recording spans 1e+06 s, more than the 3600 s a trial may last "
                              "(--max-trial-s); is t_s in seconds?"));
  EXPECT_FALSE(fs::exists(dir_ / "replay.csv"));

  const fs::path population = dir_ / "population.json";
  fs::copy_file(fs::path(HAPTICLAB_SOURCE_DIR) / "examples" / "population" / "fitted.json", population);
  const auto size = fs::file_size(population);
  std::tie(rc, text) = cli("sim run --settings " + hf + " --population " + population.string() + " --out " +
                           population.string() + " --max-trial-s 1");
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, HasSubstr("--population"));
  EXPECT_EQ(fs::file_size(population), size);

  std::tie(rc, text) = cli("sim run --settings " + hf + " --population /dev/zero --out " +
                           (dir_ / "z.csv").string() + " --max-trial-s 1");
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, HasSubstr("/dev/zero: larger than 16 MiB, the limit for a population file"));
  std::tie(rc, text) = cli("sim run --settings " + hf + " --population " + dir_.string() + " --out " +
                           (dir_ / "z.csv").string() + " --max-trial-s 1");
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, HasSubstr("Is a directory"));
  std::tie(rc, text) = cli("sim run --settings " + hf + " --population '' --out " + (dir_ / "z.csv").string() +
                           " --max-trial-s 1");
  EXPECT_EQ(rc, 2) << text;
  EXPECT_THAT(text, HasSubstr("--population: '' is refused: name a population file, or 'unfitted'"));
  EXPECT_FALSE(fs::exists(dir_ / "z.csv"));
  // An empty file as the study: no schema at all, which no migration would
  // make a study (the message advised one).
  std::ofstream(dir_ / "empty.db").flush();
  std::tie(rc, text) = cli("sim replay --db " + (dir_ / "empty.db").string() + " --trial 1 --out " +
                           (dir_ / "r.csv").string());
  EXPECT_EQ(rc, 1) << text;
  EXPECT_THAT(text, AllOf(HasSubstr("holds no HapticLab study (no schema"), Not(HasSubstr("migrate"))));
}

// Options a command would not use are refused by name, not ignored: the
// fit draws its own participants; --quick picks a shipped protocol; a
// database trial has its own task; a CSV holds one recording. Each is
// refused before anything is written.
TEST_F(NamedRefusalsTest, OptionsThatWouldBeIgnoredAreRefused) {
  const std::string out = (dir_ / "out").string();
  for (const auto& [args, why] : std::vector<std::pair<std::string, std::string>>{
           {"plan calibrate --fit --population unfitted --out " + out, "--fit excludes --population"},
           {"plan calibrate --fit --participants 7 --out " + out, "--fit excludes --participants"},
           {"plan calibrate --fit-studies 3 --out " + out, "--fit-studies requires --fit"},
           {"demo --quick --protocol " + protocol("q.json", two_settings()).string() + " --out " + out,
            "--quick excludes --protocol"}}) {
    const auto [rc, text] = cli(args);
    EXPECT_EQ(rc, 2) << args;
    EXPECT_THAT(text, HasSubstr(why)) << args;
  }
  const fs::path db = dir_ / "s.db";
  ASSERT_EQ(cli("study create --protocol " + protocol("s.json", two_settings()).string() + " --db " + db.string()).first,
            0);
  ASSERT_EQ(cli("session run --db " + db.string() + " --participant A --training-trials 0 --max-trials 1").first, 0);
  auto [rc, text] = cli("sim replay --db " + db.string() + " --trial 1 --task dissection --out " + out + ".csv");
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, HasSubstr("--task: not with --db (the trial's own task, recorded in the study, is replayed)"));
  const fs::path csv = dir_ / "trajectory.csv";
  std::ofstream(csv) << "t_s\n";
  std::tie(rc, text) = cli("sim replay --csv " + csv.string() + " --trial 1 --task clip --settings " +
                           (kSettings / "high_fidelity.json").string() + " --out " + out + ".csv");
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, HasSubstr("--trial: only with --db (a CSV is one recording)"));
  EXPECT_FALSE(fs::exists(out)) << "a refused command wrote its output";
  EXPECT_FALSE(fs::exists(out + ".csv")) << "a refused command wrote its output";
}

// Standard output on a full disk (/dev/full): what a command printed is
// lost, so it does not exit 0; the error says why. Help, a settings check
// and a study's summary, each a command whose output is its result.
TEST_F(NamedRefusalsTest, OutputThatCannotBeWrittenIsAFailureNotExitZero) {
  const fs::path db = dir_ / "full.db";
  ASSERT_EQ(cli("study create --protocol " + protocol("full.json", two_settings()).string() + " --db " + db.string()).first,
            0);
  for (const std::string& args : {std::string("study --help"),
                                   "settings check " + (kSettings / "high_fidelity.json").string(),
                                   "study show --db " + db.string()}) {
    ASSERT_EQ(cli(args).first, 0) << args;  // the same command with a working stdout
    const auto [rc, text] = testing::run_shell(std::string(HAPTICLAB_CLI_PATH) + " " + args + " 2>&1 >/dev/full");
    EXPECT_EQ(rc, 1) << args;
    EXPECT_THAT(text, AllOf(HasSubstr("hapticlab: error: cannot write to standard output"),
                            HasSubstr("what the command printed is incomplete")))
        << args;
  }
}

TEST_F(NamedRefusalsTest, SettingNamesAreUniqueIgnoringCaseSpacesPunctuationAndAccents) {
  const fs::path p = protocol("case.json", "\"" + (kSettings / "high_fidelity.json").string() +
                                               R"(", {"name": " high fidelity", "translation": {"friction": {}}})");
  auto [rc, text] = cli("study create --protocol " + p.string() + " --db " + (dir_ / "case.db").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr("protocol field 'settings[1].name' is \" high fidelity\", the same as settings[0] "
                                    "(\"High Fidelity\") but for case, spaces, punctuation or accents"),
                          HasSubstr("a reader could not tell them apart")));
  EXPECT_FALSE(fs::exists(dir_ / "case.db"));
  // Names that look alike, found by an outside check after a study had
  // run on them: a no-break space, a dash, and "Café" composed beside
  // "Café" decomposed. Each is refused before anything runs, by every
  // command that reads a protocol, the bytes shown.
  const struct {
    const char* first;
    const char* second;
    const char* shown;
  } alike[] = {{"High Fidelity", "High\u00a0Fidelity", "\"High\\xC2\\xA0Fidelity\""},
               {"High Fidelity", "High-Fidelity", "\"High-Fidelity\""},
               {"Caf\u00e9", "Cafe\u0301", "\"Cafe\\xCC\\x81\""}};
  for (const auto& a : alike) {
    const fs::path q = protocol("alike.json", std::string(R"({"name": ")") + a.first + R"("}, {"name": ")" + a.second +
                                                  R"(", "translation": {"friction": {}}})");
    std::tie(rc, text) = cli("study create --protocol " + q.string() + " --db " + (dir_ / "alike.db").string());
    EXPECT_EQ(rc, 1) << a.second;
    EXPECT_THAT(text, AllOf(HasSubstr("'settings[1].name' is " + std::string(a.shown)),
                            HasSubstr("but for case, spaces, punctuation or accents")))
        << a.second;
    EXPECT_FALSE(fs::exists(dir_ / "alike.db"));
    std::tie(rc, text) = cli("plan power --protocol " + q.string() + " --studies 1 --no-plots --out " +
                             (dir_ / "plan").string());
    EXPECT_EQ(rc, 1) << a.second;
    EXPECT_THAT(text, HasSubstr("'settings[1].name'")) << a.second;
  }
  // Beyond Latin-1 (an outside check): Polish and Czech letters in either
  // case, and composed beside decomposed, were two settings.
  for (const auto& [first, second] : std::vector<std::pair<std::string, std::string>>{
           {"\u0141\u00f3d\u017a", "\u0142\u00f3d\u017a"}, {"T\u0159en\u00ed", "Tr\u030cen\u00ed"}}) {
    const fs::path q =
        protocol("alike2.json", R"({"name": ")" + first + R"("}, {"name": ")" + second + R"(", "translation": {"friction": {}}})");
    std::tie(rc, text) = cli("study create --protocol " + q.string() + " --db " + (dir_ / "alike2.db").string());
    EXPECT_EQ(rc, 1) << second;
    EXPECT_THAT(text, HasSubstr("but for case, spaces, punctuation or accents")) << second;
  }
  // Names a reader tells apart are still settings of their own: a number's
  // sign and decimal point count (a dose series' "f = -0.5" and "f = 0.5").
  const fs::path apart = protocol("apart.json", R"({"name": "High Fidelity"}, {"name": "Caf\u00e8", "translation": )"
                                                R"({"friction": {}}}, {"name": "Caf\u00e9 2", "translation": )"
                                                R"({"friction": {}}}, {"name": "Delay +20 ms"}, {"name": "Delay -20 ms"},)"
                                                R"( {"name": "Delay 20 ms"}, {"name": "f = 0.5"}, {"name": "f = 05"})");
  std::tie(rc, text) = cli("study create --protocol " + apart.string() + " --db " + (dir_ / "apart.db").string());
  EXPECT_EQ(rc, 0) << text;
}

// A setting named "Strong Friction\u0000 v2" was stored, shown and analysed
// as "Strong Friction", beside another "Strong Friction" (an outside
// check); a newline broke the tables, a name of spaces showed blank. Each
// is refused, and so is such a study name.
TEST_F(NamedRefusalsTest, SettingAndStudyNamesArePrintableText) {
  for (const auto& [name, why] : std::vector<std::pair<std::string, std::string>>{
           {"Strong Friction\\u0000 v2", "holds a control character"},
           {"Strong\\nFriction", "holds a control character"},
           {"Strong\\u0085Friction", "holds a control character"},
           {"   ", "has no letter or digit"},
           {"--", "has no letter or digit"}}) {
    const fs::path q = protocol("names.json", "\"" + (kSettings / "high_fidelity.json").string() + R"(", {"name": ")" +
                                                  name + R"(", "translation": {"friction": {}}})");
    const auto [rc, text] = cli("study create --protocol " + q.string() + " --db " + (dir_ / "names.db").string());
    EXPECT_EQ(rc, 1) << name;
    EXPECT_THAT(text, AllOf(HasSubstr("'settings[1].name'"), HasSubstr(why))) << name;
    EXPECT_FALSE(fs::exists(dir_ / "names.db"));
  }
  for (const std::string study : {"a\\u0000b", "  "}) {
    const fs::path q = dir_ / "study_name.json";
    std::ofstream(q) << R"({"study": ")" << study << R"(", "tasks": ["clip"], "repetitions": {"clip": 1}, "settings": [)"
                     << two_settings() << R"(], "participants": ["A", "B"], "design": {"type": "complete"}, "seed": 5})";
    const auto [rc, text] = cli("study create --protocol " + q.string() + " --db " + (dir_ / "names.db").string());
    EXPECT_EQ(rc, 1) << study;
    EXPECT_THAT(text, AllOf(HasSubstr("protocol field 'study'"), HasSubstr("printable text"))) << study;
  }
}

// An incomplete design with too few participants left a listed setting
// without a trial, and `study create` said nothing (an outside check): the
// study ran without it. A warning names it; the study is still made.
TEST_F(NamedRefusalsTest, ASettingNoParticipantRunsIsAWarning) {
  const fs::path q = protocol("unused.json", two_settings() + R"(, {"name": "Friction", "translation": {"friction": {}}},)"
                                                              R"( {"name": "Cogging", "translation": {"cogging": {}}})");
  std::string text;
  {
    std::ifstream in(q);
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::string complete = R"("design": {"type": "complete"})";
  text.replace(text.find(complete), complete.size(),
               R"("design": {"type": "incomplete", "required": ["High Fidelity"], "k": 1})");
  std::ofstream(q) << text;
  const auto [rc, out] = cli("study create --protocol " + q.string() + " --db " + (dir_ / "unused.db").string());
  EXPECT_EQ(rc, 0) << out;
  // Two participants, one optional setting each, three optional settings:
  // one at least is left out.
  EXPECT_THAT(out, HasSubstr("is in no participant's schedule (the design gives it no trials with these 2 "
                             "participants), so it will not be run"));
  const auto [rc_full, out_full] = cli("study create --protocol " + protocol("used.json", two_settings()).string() +
                                       " --db " + (dir_ / "used.db").string());
  EXPECT_EQ(rc_full, 0) << out_full;
  EXPECT_THAT(out_full, Not(HasSubstr("warning")));
}

// "S1" and "s1" were two participants: an operator who typed one ran the
// other's schedule, and a merge counted one person at two sites as two.
TEST_F(NamedRefusalsTest, ParticipantCodesAreUniqueIgnoringCase) {
  const fs::path p = dir_ / "codes.json";
  std::ofstream(p) << R"({"study": "named", "tasks": ["clip"], "repetitions": {"clip": 1}, "settings": [)"
                   << two_settings() << R"(], "participants": ["S1", "S2", "s1"], "design": {"type": "complete"},)"
                   << R"( "seed": 5})";
  const auto [rc, text] = cli("study create --protocol " + p.string() + " --db " + (dir_ / "codes.db").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, HasSubstr("protocol field 'participants[2].code' is \"s1\", the same as participants[0] (\"S1\") "
                              "but for case; codes must be unique ignoring case"));
  EXPECT_FALSE(fs::exists(dir_ / "codes.db"));
}

// A study file on a read-only file system (an archive, read-only media):
// SQLite cannot create the -shm its WAL mode needs, and the check that
// then failed called an intact file "damaged" -- an operator may throw
// such a file away. Said as what it is, with the way out.
TEST_F(NamedRefusalsTest, AFileOnAReadOnlyFileSystemIsUnreadableNotDamaged) {
  if (std::system("unshare -m sh -c 'mount -t tmpfs -o size=64k tmpfs /mnt' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "mounting a tmpfs needs root in a mount namespace";
  const fs::path db = dir_ / "ro.db";
  ASSERT_EQ(cli("study create --protocol " + protocol("ro.json", two_settings()).string() + " --db " + db.string()).first,
            0);
  const fs::path mnt = dir_ / "mnt";
  fs::create_directories(mnt);
  const std::string h = HAPTICLAB_CLI_PATH;
  const std::string script = "mount -t tmpfs -o size=4m tmpfs " + mnt.string() + " && cp " + db.string() + " " +
                             mnt.string() + "/ && mount -o remount,ro " + mnt.string() + " && " + h +
                             " study show --db " + mnt.string() + "/ro.db --summary; rc1=$?; " + h +
                             " study check --db " + mnt.string() + "/ro.db; rc2=$?; exit $((rc1 * 10 + rc2))";
  const auto [status, out] = testing::run_cli("unshare", "-m sh -c '" + script + "' 2>&1");
  EXPECT_EQ(status, 11) << out;
  EXPECT_THAT(out, AllOf(HasSubstr("ro.db: cannot be read here"), HasSubstr("on a read-only file system or folder, "
                                                                              "copy the file"),
                         HasSubstr("Nothing here says the file is damaged"), Not(HasSubstr("file is damaged:")),
                         Not(HasSubstr("integrity_check itself failed"))));
}

TEST_F(NamedRefusalsTest, AStaircaseWithAnExternalVeIsRefused) {
  const fs::path p = dir_ / "external.json";
  std::ofstream(p) << R"({"study": "ext", "ve": "external", "tasks": ["peg"], "repetitions": {"peg": 1},
    "settings": [{"name": "High Fidelity"}], "participants": ["A"], "design": {"type": "complete"}, "seed": 1,
    "staircase": {"settings": {"name": "Friction", "translation": {"friction": {}}},
                  "field": "translation.friction.dynamic_level_N", "measure": "force_p95_N", "change": 0.2,
                  "baseline": "High Fidelity", "start": 0.5, "step": 0.1, "min": 0.0, "max": 1.0}})";
  const auto [rc, text] = cli("study create --protocol " + p.string() + " --db " + (dir_ / "ext.db").string());
  EXPECT_EQ(rc, 1);
  EXPECT_THAT(text, AllOf(HasSubstr("protocol field 'staircase' is given with \"ve\": \"external\""),
                          HasSubstr("never runs a staircase")));
  EXPECT_FALSE(fs::exists(dir_ / "ext.db"));
}

}  // namespace
}  // namespace hapticlab::app
