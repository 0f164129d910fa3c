// The protocol's optional "safety" object: read into OperatorForceLimits,
// every field checked with the field's path, the value and the range.
#include "protocols/safety_json.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "protocols/protocol_json.h"

namespace hapticlab::protocols {
namespace {

using nlohmann::json;

const std::filesystem::path kShippedProtocolsDir = std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples" / "protocols";

json protocol_with(const json& safety) {
  json j = json::parse(R"({
    "study": "safety test",
    "tasks": ["dissection"],
    "repetitions": {"dissection": 1},
    "settings": ["../settings/high_fidelity.json", "../settings/no_force_feedback.json"],
    "participants": ["S1"],
    "design": {"type": "complete"},
    "seed": 1
  })");
  if (!safety.is_null()) j["safety"] = safety;
  return j;
}

ProtocolError error_of(const json& safety) {
  try {
    protocol_from_json(protocol_with(safety), kShippedProtocolsDir, "study.json");
  } catch (const ProtocolError& e) {
    return e;
  }
  return ProtocolError("(none)", "(none)", "no error");
}

TEST(SafetyJsonTest, EveryFieldIsReadAndMissingOnesKeepTheDevicesLimits) {
  const Protocol p = protocol_from_json(protocol_with(json::parse(R"({
      "peak_force_fraction": 0.5, "max_insertion_force_N": 8, "max_pitch_yaw_torque_Nm": 0.4,
      "max_twist_torque_Nm": 0.05, "max_grip_torque_Nm": 0})")),
                                        kShippedProtocolsDir, "study.json");
  EXPECT_EQ(p.safety.peak_force_fraction, 0.5);
  EXPECT_EQ(p.safety.insertion_force_N, 8.0);
  EXPECT_EQ(p.safety.pitch_yaw_torque_Nm, 0.4);
  EXPECT_EQ(p.safety.twist_torque_Nm, 0.05);
  EXPECT_EQ(p.safety.grip_torque_Nm, 0.0);

  const Protocol none = protocol_from_json(protocol_with(json()), kShippedProtocolsDir, "study.json");
  EXPECT_EQ(none.safety.peak_force_fraction, 1.0);
  EXPECT_EQ(none.safety.insertion_force_N, OperatorForceLimits::kNoLimit);
  EXPECT_EQ(none.safety.grip_torque_Nm, OperatorForceLimits::kNoLimit);
}

TEST(SafetyJsonTest, ErrorsNameTheFieldTheValueAndTheRange) {
  ProtocolError e = error_of(json::parse(R"({"peak_force_fraction": 1.5})"));
  EXPECT_EQ(e.field(), "safety.peak_force_fraction");
  EXPECT_EQ(std::string(e.what()),
            "study.json: protocol field 'safety.peak_force_fraction' is 1.5, but must be a number >= 0 and <= 1.0");
  e = error_of(json::parse(R"({"max_insertion_force_N": -2})"));
  EXPECT_EQ(e.field(), "safety.max_insertion_force_N");
  EXPECT_NE(std::string(e.what()).find("is -2, but must be a number >= 0 and <= 1000.0"), std::string::npos)
      << e.what();
  e = error_of(json::parse(R"({"max_grip_torque_Nm": "0.1"})"));
  EXPECT_EQ(e.field(), "safety.max_grip_torque_Nm");
  e = error_of(json::parse(R"({"max_force_N": 3})"));
  EXPECT_EQ(e.field(), "safety.max_force_N");
  EXPECT_NE(std::string(e.what()).find("is not a known field; allowed here: peak_force_fraction, "), std::string::npos)
      << e.what();
  e = error_of(json(0.5));
  EXPECT_EQ(e.field(), "safety");
}

// A limit of 0 for every force left no setting with force feedback, the
// control included, and the study ran without a word.
TEST(SafetyJsonTest, LimitsThatLeaveNoForceFeedbackAnywhereAreRefusedAtCreation) {
  ProtocolError e = error_of(json::parse(R"({"peak_force_fraction": 0})"));
  EXPECT_EQ(e.field(), "safety.peak_force_fraction");
  EXPECT_NE(std::string(e.what()).find("is 0, which clamps every force of every trial to zero"), std::string::npos)
      << e.what();
  e = error_of(json::parse(R"({"max_insertion_force_N": 0, "max_pitch_yaw_torque_Nm": 0})"));
  EXPECT_EQ(e.field(), "safety.max_insertion_force_N");
  EXPECT_NE(std::string(e.what()).find("safety.max_pitch_yaw_torque_Nm is 0 too"), std::string::npos) << e.what();
  // One joint group without force stays allowed (the grip above, insertion here).
  EXPECT_EQ(protocol_from_json(protocol_with(json::parse(R"({"max_insertion_force_N": 0})")), kShippedProtocolsDir,
                               "study.json")
                .safety.insertion_force_N,
            0.0);
  // A stored protocol is read back as it is: a study created before keeps working.
  EXPECT_EQ(safety_from_protocol_text(protocol_with(json::parse(R"({"peak_force_fraction": 0})")).dump(), "study.db")
                .peak_force_fraction,
            0.0);
}

TEST(SafetyJsonTest, StoredProtocolTextGivesTheSameLimits) {
  const std::string text = protocol_with(json::parse(R"({"max_pitch_yaw_torque_Nm": 0.25})")).dump();
  const OperatorForceLimits limits = safety_from_protocol_text(text, "study.db");
  EXPECT_EQ(limits.pitch_yaw_torque_Nm, 0.25);
  EXPECT_EQ(limits.insertion_force_N, OperatorForceLimits::kNoLimit);
  EXPECT_EQ(safety_from_protocol_text(protocol_with(json()).dump(), "study.db").peak_force_fraction, 1.0);
}

}  // namespace
}  // namespace hapticlab::protocols
