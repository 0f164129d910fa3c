#include "protocols/protocol_json.h"
#include "tests/protocols/protocol_failure.h"

#include "protocols/schedule.h"

#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace hapticlab::protocols {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

// A valid protocol; each test breaks one thing.
json valid() {
  return json::parse(R"({
    "study": "unit test",
    "tasks": ["dissection", "clip"],
    "repetitions": {"dissection": 3, "clip": 9},
    "settings": ["../settings/high_fidelity.json", "../settings/no_force_feedback.json",
                 "../settings/all_degradations.json", "../settings/cogging.json",
                 {"name": "Inline Friction", "translation": {"friction": {"dynamic_level_N": 0.3}}}],
    "participants": ["S1", {"code": "S2", "tasks": ["clip"], "training_trials": 4}],
    "design": {"type": "incomplete", "required": ["High Fidelity", "No Force Feedback"], "k": 1},
    "seed": 18446744073709551615
  })");
}

Protocol parse(const json& j) { return protocol_from_json(j, testing::kExampleProtocolsDir, "test.json"); }

using testing::Failure;

Failure failure_of(const json& j) { return testing::protocol_failure(j, testing::kExampleProtocolsDir); }

TEST(ProtocolJsonTest, ValidProtocolReadsEveryField) {
  const Protocol p = parse(valid());
  EXPECT_EQ(p.study, "unit test");
  EXPECT_EQ(p.tasks, (std::vector<Task>{Task::kDissection, Task::kClip}));
  EXPECT_EQ(p.repetitions_of(Task::kDissection), 3);
  EXPECT_EQ(p.repetitions_of(Task::kClip), 9);
  ASSERT_EQ(p.settings.size(), 5u);
  EXPECT_EQ(p.settings[0].settings.name, "High Fidelity");
  EXPECT_EQ(p.settings[0].source, "../settings/high_fidelity.json");
  EXPECT_EQ(p.settings[4].source, "inline");
  EXPECT_TRUE(p.settings[4].settings.engine.translation.friction.enabled);
  EXPECT_DOUBLE_EQ(p.settings[4].settings.engine.translation.friction.dynamic_level, 0.3);
  ASSERT_EQ(p.participants.size(), 2u);
  EXPECT_EQ(p.participants[0].code, "S1");
  EXPECT_EQ(p.participants[0].tasks, p.tasks);
  EXPECT_EQ(p.participants[0].training_trials, 0);
  EXPECT_EQ(p.participants[1].tasks, std::vector<Task>{Task::kClip});
  EXPECT_EQ(p.participants[1].training_trials, 4);
  EXPECT_EQ(p.design.type, DesignType::kIncomplete);
  EXPECT_EQ(p.design.k, 1);
  EXPECT_EQ(p.seed, 18446744073709551615ULL);
}

TEST(ProtocolJsonTest, UnknownSettingNameInRequired) {
  json j = valid();
  j["design"]["required"][1] = "No Force Feedbak";
  const Failure f = failure_of(j);
  EXPECT_EQ(f.field, "design.required[1]");
  EXPECT_THAT(f.message, HasSubstr("\"No Force Feedbak\""));
  EXPECT_THAT(f.message, HasSubstr("\"No Force Feedback\""));  // lists the known names
  EXPECT_THAT(f.message, HasSubstr("test.json"));
}

TEST(ProtocolJsonTest, UnknownSettingNameInExplicitAssignments) {
  json j = valid();
  j["design"] = {{"type", "explicit"},
                 {"assignments", {{"S1", {"High Fidelity", "Cogging"}}, {"S2", {"High Fidelity", "Backlash"}}}}};
  const Failure f = failure_of(j);
  EXPECT_EQ(f.field, "design.assignments.S2[1]");
  EXPECT_THAT(f.message, HasSubstr("\"Backlash\""));
}

TEST(ProtocolJsonTest, ExplicitAssignmentsMustCoverExactlyTheParticipants) {
  json j = valid();
  j["design"] = {{"type", "explicit"}, {"assignments", {{"S1", {"High Fidelity", "Cogging"}}}}};
  EXPECT_EQ(failure_of(j).field, "design.assignments.S2");
  j["design"]["assignments"]["S2"] = {"High Fidelity", "Cogging"};
  j["design"]["assignments"]["S9"] = {"High Fidelity", "Cogging"};
  EXPECT_EQ(failure_of(j).field, "design.assignments.S9");
  j["design"]["assignments"].erase("S9");
  EXPECT_NO_THROW(parse(j));
  j["design"]["assignments"]["S2"] = {"High Fidelity", "Cogging", "Cogging"};
  EXPECT_EQ(failure_of(j).field, "design.assignments.S2[2]");
}

TEST(ProtocolJsonTest, KOutOfRange) {
  json j = valid();
  j["design"]["k"] = 4;  // 5 settings, 2 required: 3 optional
  Failure f = failure_of(j);
  EXPECT_EQ(f.field, "design.k");
  EXPECT_THAT(f.message, HasSubstr("is 4"));
  EXPECT_THAT(f.message, HasSubstr(">= 0 and <= 3"));
  j["design"]["k"] = -1;
  f = failure_of(j);
  EXPECT_EQ(f.field, "design.k");
  EXPECT_THAT(f.message, HasSubstr("is -1"));
  j["design"]["k"] = 1.5;
  EXPECT_EQ(failure_of(j).field, "design.k");
  j["design"]["k"] = 3;
  EXPECT_NO_THROW(parse(j));
}

TEST(ProtocolJsonTest, KBuiltInCodeIsCheckedToo) {
  Protocol p = parse(valid());
  p.design.k = 7;
  try {
    validate_protocol(p, "code");
    FAIL();
  } catch (const ProtocolError& e) {
    EXPECT_EQ(e.field(), "design.k");
    EXPECT_THAT(e.what(), HasSubstr("<= 3"));
  }
}

TEST(ProtocolJsonTest, ZeroOrTooManyRepetitions) {
  json j = valid();
  j["repetitions"]["clip"] = 0;
  Failure f = failure_of(j);
  EXPECT_EQ(f.field, "repetitions.clip");
  EXPECT_THAT(f.message, HasSubstr("is 0"));
  EXPECT_THAT(f.message, HasSubstr(">= 1 and <= 100"));
  j["repetitions"]["clip"] = 101;
  EXPECT_EQ(failure_of(j).field, "repetitions.clip");
  j["repetitions"].erase("clip");
  f = failure_of(j);
  EXPECT_EQ(f.field, "repetitions.clip");
  EXPECT_THAT(f.message, HasSubstr("missing"));
  // 2.0 is a whole number to a reader: the message says what is refused,
  // the way it is written (it once read "is 2.0, but must be a whole number").
  j["repetitions"]["clip"] = 2.0;
  f = failure_of(j);
  EXPECT_THAT(f.message, HasSubstr("is 2.0, but must be a whole number >= 1 and <= 100"));
  EXPECT_THAT(f.message, HasSubstr(", written without a decimal point or exponent"));
  j["repetitions"]["clip"] = 2;
  j["seed"] = 5.0;
  EXPECT_THAT(failure_of(j).message, HasSubstr("written without a decimal point or exponent"));
  // 2^64 is read as a double: said as too large, not as "1.8446744073709552e+19".
  j["seed"] = json::parse("18446744073709551616");
  EXPECT_THAT(failure_of(j).message, HasSubstr("is larger than 18446744073709551615, but must be a whole number"));
}

TEST(ProtocolJsonTest, DuplicateParticipantCodes) {
  json j = valid();
  j["participants"] = {"S1", "S2", "S1"};
  const Failure f = failure_of(j);
  EXPECT_EQ(f.field, "participants[2].code");
  EXPECT_THAT(f.message, HasSubstr("\"S1\""));
  EXPECT_THAT(f.message, HasSubstr("unique"));
}

TEST(ProtocolJsonTest, NamesAreRefusedCodesOnly) {
  json j = valid();
  j["participants"][0] = "John Smith";
  Failure f = failure_of(j);
  EXPECT_EQ(f.field, "participants[0]");
  EXPECT_THAT(f.message, HasSubstr("looks like a person's name"));
  EXPECT_THAT(f.message, HasSubstr("codes only, never names"));
  j["participants"][0] = json{{"code", "Dr. Jones"}};
  f = failure_of(j);
  EXPECT_EQ(f.field, "participants[0].code");
  EXPECT_THAT(f.message, HasSubstr("never names"));
  j["participants"][0] = "S1/x";
  EXPECT_EQ(failure_of(j).field, "participants[0]");
  j["participants"][0] = "";
  EXPECT_EQ(failure_of(j).field, "participants[0]");
  j["participants"][0] = std::string(33, 'a');
  EXPECT_EQ(failure_of(j).field, "participants[0]");
  j["participants"][0] = std::string(32, 'a');
  EXPECT_NO_THROW(parse(j));
}

TEST(ProtocolJsonTest, UnknownTask) {
  json j = valid();
  j["tasks"][1] = "suturing";
  Failure f = failure_of(j);
  EXPECT_EQ(f.field, "tasks[1]");
  EXPECT_THAT(f.message, HasSubstr("\"suturing\""));
  EXPECT_THAT(f.message, HasSubstr("\"dissection\", \"clip\""));
  j = valid();
  j["participants"][1]["tasks"] = {"knot"};
  EXPECT_EQ(failure_of(j).field, "participants[1].tasks[0]");
  j = valid();
  j["repetitions"]["knot"] = 3;
  EXPECT_EQ(failure_of(j).field, "repetitions.knot");
}

TEST(ProtocolJsonTest, ParticipantTaskOutsideTheStudy) {
  json j = valid();
  j["tasks"] = {"dissection"};
  j["repetitions"].erase("clip");
  const Failure f = failure_of(j);
  EXPECT_EQ(f.field, "participants[1].tasks[0]");
  EXPECT_THAT(f.message, HasSubstr("not one of the study's tasks"));
}

TEST(ProtocolJsonTest, MissingFields) {
  for (const char* key : {"study", "tasks", "repetitions", "settings", "participants", "design", "seed"}) {
    json j = valid();
    j.erase(key);
    const Failure f = failure_of(j);
    EXPECT_EQ(f.field, key);
    EXPECT_THAT(f.message, HasSubstr("missing"));
  }
  json j = valid();
  j["design"].erase("k");
  EXPECT_EQ(failure_of(j).field, "design.k");
  j = valid();
  j["participants"][1].erase("code");
  EXPECT_EQ(failure_of(j).field, "participants[1].code");
}

TEST(ProtocolJsonTest, UnknownFields) {
  json j = valid();
  j["seeds"] = 3;
  Failure f = failure_of(j);
  EXPECT_EQ(f.field, "seeds");
  EXPECT_THAT(f.message, HasSubstr("not a known field"));
  j = valid();
  j["design"]["optional"] = {"Cogging"};
  EXPECT_EQ(failure_of(j).field, "design.optional");
  j = valid();
  j["participants"][1]["name"] = "Jane";
  EXPECT_EQ(failure_of(j).field, "participants[1].name");
  j = valid();
  j["design"] = {{"type", "complete"}, {"k", 2}};
  EXPECT_EQ(failure_of(j).field, "design.k");
  j["design"] = {{"type", "latin-square"}};
  EXPECT_EQ(failure_of(j).field, "design.type");
}

TEST(ProtocolJsonTest, SeedMustBeAnUnsigned64BitInteger) {
  for (json bad : {json(-1), json(1.5), json("42"), json(nullptr)}) {
    json j = valid();
    j["seed"] = bad;
    const Failure f = failure_of(j);
    EXPECT_EQ(f.field, "seed") << bad;
    EXPECT_THAT(f.message, HasSubstr("unsigned 64-bit"));
  }
  json j = valid();
  j["seed"] = 0;
  EXPECT_EQ(parse(j).seed, 0u);
}

TEST(ProtocolJsonTest, SettingsFileThatFailsToLoad) {
  json j = valid();
  j["settings"][2] = "../settings/no_such_file.json";
  Failure f = failure_of(j);
  EXPECT_EQ(f.field, "settings[2]");
  EXPECT_THAT(f.message, HasSubstr("no_such_file.json"));
  EXPECT_THAT(f.message, HasSubstr("cannot open settings file"));  // the SettingsError text

  j = valid();
  j["settings"][4]["translation"]["friction"]["dynamic_level_N"] = -1;
  f = failure_of(j);
  EXPECT_EQ(f.field, "settings[4]");
  EXPECT_THAT(f.message, HasSubstr("dynamic_level_N"));  // the SettingsError text names the field
}

TEST(ProtocolJsonTest, SettingsNeedUniqueNames) {
  json j = valid();
  j["settings"][4] = "../settings/cogging.json";
  Failure f = failure_of(j);
  EXPECT_EQ(f.field, "settings[4].name");
  EXPECT_THAT(f.message, HasSubstr("unique"));
  j = valid();
  j["settings"][4].erase("name");
  EXPECT_EQ(failure_of(j).field, "settings[4].name");
}

TEST(ProtocolJsonTest, EveryParticipantNeedsTwoSettings) {
  json j = valid();
  j["design"] = {{"type", "incomplete"}, {"required", {"High Fidelity"}}, {"k", 0}};
  const Failure f = failure_of(j);
  EXPECT_EQ(f.field, "design");
  EXPECT_THAT(f.message, HasSubstr("at least 2"));
}

TEST(ProtocolJsonTest, WrongTypesAndBadJson) {
  json j = valid();
  j["participants"] = "S1";
  EXPECT_EQ(failure_of(j).field, "participants");
  j = valid();
  j["settings"][0] = 3;
  EXPECT_EQ(failure_of(j).field, "settings[0]");
  try {
    protocol_from_json_text("{ \"study\": ", testing::kExampleProtocolsDir, "broken.json");
    FAIL();
  } catch (const ProtocolError& e) {
    EXPECT_THAT(e.what(), HasSubstr("broken.json"));
    EXPECT_THAT(e.what(), HasSubstr("not valid JSON"));
  }
  EXPECT_THROW(load_protocol_file(testing::kExampleProtocolsDir / "does_not_exist.json"), ProtocolError);
}

// Issue 15: with "ve": "external" the tasks are the lab's own, named freely;
// the simulated VE (the default) still knows only its two.
json external(const std::vector<std::string>& tasks) {
  json j = valid();
  j["ve"] = "external";
  j["tasks"] = tasks;
  j["repetitions"] = json::object();
  for (const std::string& t : tasks) j["repetitions"][t] = 2;
  j["participants"] = {"S1", "S2", "S3"};
  return j;
}

TEST(ProtocolJsonTest, ExternalVeTakesTheLabsOwnTaskNames) {
  const Protocol p = parse(external({"peg touch", "Naht (Knoten) #2"}));
  EXPECT_EQ(p.ve, Ve::kExternal);
  ASSERT_EQ(p.tasks.size(), 2u);
  EXPECT_EQ(task_name(p.tasks[0]), "peg touch");
  EXPECT_EQ(p.repetitions_of(Task("Naht (Knoten) #2")), 2);
  EXPECT_EQ(parse(valid()).ve, Ve::kSimulated);  // the default
  // The same name under the simulated VE is refused, pointing at "ve".
  json j = external({"peg touch"});
  j.erase("ve");
  const Failure f = failure_of(j);
  EXPECT_EQ(f.field, "tasks[0]");
  EXPECT_THAT(f.message, HasSubstr("\"ve\": \"external\""));
}

TEST(ProtocolJsonTest, ExternalTaskNamesMustBeSane) {
  EXPECT_EQ(failure_of(external({""})).field, "tasks[0]");
  EXPECT_THAT(failure_of(external({""})).message, HasSubstr("1 to 64 bytes"));
  EXPECT_EQ(failure_of(external({"peg", std::string(65, 'x')})).field, "tasks[1]");
  EXPECT_NO_THROW(parse(external({std::string(64, 'x')})));
  EXPECT_THAT(failure_of(external({"peg\ttouch"})).message, HasSubstr("control character"));
  // The check setting and study names share: a C1 control (U+0085) too.
  EXPECT_THAT(failure_of(external({"peg\u0085touch"})).message, HasSubstr("control character"));
  EXPECT_THAT(failure_of(external({" peg"})).message, HasSubstr("space"));
  json j = external({"peg"});
  j["tasks"] = {"peg", 3};
  EXPECT_EQ(failure_of(j).field, "tasks[1]");
  j = external({"peg", "peg"});
  EXPECT_THAT(failure_of(j).message, HasSubstr("already listed"));
  j = external({"peg"});
  j["ve"] = "unity";
  EXPECT_EQ(failure_of(j).field, "ve");
  EXPECT_THAT(failure_of(j).message, HasSubstr("\"simulated\""));
}

TEST(ProtocolJsonTest, ExternalTasksAreScheduledAndCounterbalanced) {
  // Two tasks: paired like dissection/clip (each pair has one of each
  // first). Three: rotations, so each task leads once in three participants.
  const StudyPlan two = make_study_plan(parse(external({"peg", "ring"})));
  ASSERT_EQ(two.participants.size(), 3u);
  EXPECT_NE(two.participants[0].task_order.front(), two.participants[1].task_order.front());
  // valid()'s design: 2 required settings + k = 1 others; x 2 repetitions x 2 tasks.
  EXPECT_EQ(two.participants[0].trials.size(), 3u * 2u * 2u);
  const StudyPlan three = make_study_plan(parse(external({"peg", "ring", "wire"})));
  std::set<std::string> firsts;
  for (const ParticipantPlan& pp : three.participants) firsts.insert(task_name(pp.task_order.front()).data());
  EXPECT_EQ(firsts, (std::set<std::string>{"peg", "ring", "wire"}));
}

}  // namespace
}  // namespace hapticlab::protocols

namespace hapticlab::protocols {
namespace {

// Issue 33: the update rate is a controlled variable, so how far a session's
// achieved rate may stray is the protocol's to say, with a stated default.
TEST(ProtocolJsonTest, RateToleranceIsReadWithItsDefaultAndRange) {
  EXPECT_DOUBLE_EQ(parse(valid()).rate_tolerance_fraction, 0.10);
  json j = valid();
  j["rate_tolerance_fraction"] = 0.25;
  EXPECT_DOUBLE_EQ(parse(j).rate_tolerance_fraction, 0.25);
  EXPECT_DOUBLE_EQ(rate_tolerance_from_protocol_text(j.dump(), "study.db"), 0.25);
  EXPECT_DOUBLE_EQ(rate_tolerance_from_protocol_text(valid().dump(), "study.db"), 0.10);
  for (const json& bad : {json(0.0), json(0.6), json("10%"), json(nullptr)}) {
    j["rate_tolerance_fraction"] = bad;
    const Failure f = failure_of(j);
    EXPECT_EQ(f.field, "rate_tolerance_fraction") << bad;
    EXPECT_THAT(f.message, HasSubstr("0.001")) << f.message;
    EXPECT_THAT(f.message, HasSubstr("0.5")) << f.message;
  }
}

}  // namespace
}  // namespace hapticlab::protocols
