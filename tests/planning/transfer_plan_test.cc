// A protocol's group design as the simulated transfer studies
// (planning/transfer_plan.h), on the shipped examples/protocols/transfer_study.json.
#include "planning/transfer_plan.h"

#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "core/settings/settings_json.h"
#include "protocols/protocol_json.h"

namespace hapticlab::planning {
namespace {

protocols::Protocol shipped_transfer_protocol() {
  return protocols::load_protocol_file(std::string(HAPTICLAB_SOURCE_DIR) + "/examples/protocols/transfer_study.json");
}

std::string as_json(const EngineSettings& e) {
  NamedSettings n;
  n.engine = e;
  return settings_to_json(n).dump();
}

TEST(TransferPlanTest, TheShippedTransferStudyBecomesOneDesignPerTask) {
  const std::vector<TransferDesign> designs = transfer_designs(shipped_transfer_protocol());
  ASSERT_EQ(designs.size(), 2u);
  EXPECT_EQ(designs[0].task, "dissection");
  EXPECT_EQ(designs[1].task, "clip");
  // transfer_study.json: training_trials 2; tests 2 dissections and 3 clips;
  // training 5 sittings of 3 dissections and 6 clips; groups HF, Falcon, control.
  const TransferDesign& d = designs[0];
  EXPECT_EQ(d.familiarization_trials, 2);
  EXPECT_EQ(d.pre_trials, 2);
  EXPECT_EQ(d.post_trials, 2);
  EXPECT_EQ(d.retention_trials, 2);
  ASSERT_EQ(d.groups.size(), 3u);
  EXPECT_EQ(d.groups[0].name, "trained on High Fidelity");
  ASSERT_EQ(d.groups[0].training.size(), 1u);
  EXPECT_EQ(d.groups[0].training[0].trials, 15);
  EXPECT_EQ(d.groups[1].training[0].trials, 15);
  EXPECT_TRUE(d.groups[2].training.empty());  // the control only tests
  EXPECT_EQ(designs[1].post_trials, 3);
  EXPECT_EQ(designs[1].groups[1].training[0].trials, 30);
  // The Falcon group trains on the Falcon preset's parameters, the tests on High Fidelity's.
  EXPECT_NE(as_json(d.groups[1].training[0].settings), as_json(d.test_settings));
  EXPECT_EQ(as_json(d.groups[0].training[0].settings), as_json(d.test_settings));
  for (const TransferDesign& x : designs) EXPECT_NO_THROW(x.validate());
}

TEST(TransferPlanTest, WhatTheSimulationCannotDoIsRefusedByName) {
  protocols::Protocol p = shipped_transfer_protocol();
  for (protocols::Phase& ph : p.transfer->phases)
    if (ph.kind == protocols::PhaseKind::kRetention) ph.setting = "Novint Falcon";
  try {
    (void)transfer_designs(p);
    ADD_FAILURE() << "a retention test on another setting accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("phases.retention.setting is 'Novint Falcon'"), std::string::npos) << e.what();
  }
  p = shipped_transfer_protocol();
  p.participants[3].training_trials = 5;
  try {
    (void)transfer_designs(p);
    ADD_FAILURE() << "different training_trials accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("training_trials differ (T04 has 5"), std::string::npos) << e.what();
  }
  p = shipped_transfer_protocol();
  p.transfer.reset();
  EXPECT_THROW((void)transfer_designs(p), std::invalid_argument);
}

}  // namespace
}  // namespace hapticlab::planning
