// The loop's protections a protocol fixes for every trial of its study:
// its force limits and rate tolerance, from the protocol and from the text a
// study stores alike; the rest of LoopSafetyConfig at its defaults.
#include "protocols/loop_protections.h"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "protocols/protocol_json.h"
#include "tests/protocols/protocol_failure.h"

namespace hapticlab::protocols {
namespace {

std::string protocol_text(bool with_limits) {
  nlohmann::json j = nlohmann::json::parse(
      read_protocol_text(std::filesystem::path(testing::kExampleProtocolsDir) / "thesis_as_run.json"));
  if (with_limits) {
    j["safety"] = {{"peak_force_fraction", 0.5}, {"max_insertion_force_N", 8.0}, {"max_pitch_yaw_torque_Nm", 0.4}};
    j["rate_tolerance_fraction"] = 0.25;
  }
  return j.dump();
}

void expect_same(const LoopSafetyConfig& a, const LoopSafetyConfig& b) {
  EXPECT_EQ(a.force_limits.peak_force_fraction, b.force_limits.peak_force_fraction);
  EXPECT_EQ(a.force_limits.insertion_force_N, b.force_limits.insertion_force_N);
  EXPECT_EQ(a.force_limits.pitch_yaw_torque_Nm, b.force_limits.pitch_yaw_torque_Nm);
  EXPECT_EQ(a.force_limits.twist_torque_Nm, b.force_limits.twist_torque_Nm);
  EXPECT_EQ(a.force_limits.grip_torque_Nm, b.force_limits.grip_torque_Nm);
  EXPECT_EQ(a.rate.tolerance_fraction, b.rate.tolerance_fraction);
  EXPECT_EQ(a.ramp_in_s, b.ramp_in_s);
  EXPECT_EQ(a.max_lateness_s, b.max_lateness_s);
  EXPECT_EQ(a.watchdog_timeout_s, b.watchdog_timeout_s);
  EXPECT_EQ(a.writer_stall_s, b.writer_stall_s);
  EXPECT_EQ(a.position_tolerance_fraction, b.position_tolerance_fraction);
}

TEST(LoopProtectionsTest, TheProtocolsLimitsAndRateToleranceTheRestDefault) {
  const std::string text = protocol_text(true);
  const LoopSafetyConfig from_text = loop_protections_from_protocol_text(text, "study.db");
  EXPECT_EQ(from_text.force_limits.peak_force_fraction, 0.5);
  EXPECT_EQ(from_text.force_limits.insertion_force_N, 8.0);
  EXPECT_EQ(from_text.force_limits.pitch_yaw_torque_Nm, 0.4);
  EXPECT_EQ(from_text.force_limits.twist_torque_Nm, OperatorForceLimits::kNoLimit);
  EXPECT_EQ(from_text.rate.tolerance_fraction, 0.25);
  LoopSafetyConfig defaults;
  defaults.force_limits = from_text.force_limits;
  defaults.rate.tolerance_fraction = 0.25;
  expect_same(from_text, defaults);
  // The parsed protocol gives the same.
  expect_same(loop_protections(protocol_from_json_text(text, testing::kExampleProtocolsDir, "p.json")), from_text);
  // Without them: the defaults, all of them.
  expect_same(loop_protections_from_protocol_text(protocol_text(false), "study.db"), LoopSafetyConfig{});
}

}  // namespace
}  // namespace hapticlab::protocols
