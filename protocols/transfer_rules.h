#pragma once
// The rules of a between-group training design (transfer_design.h), checked
// by validate_protocol when a protocol has groups. Each breach is a
// ProtocolError naming the field (issue 38 §5):
//   - a group with a declared size of 0, or declared sizes that do not sum
//     to the participant count;
//   - a group whose training setting is not one of the settings;
//   - phases out of order: a test before training that must come after it
//     (post_test or retention before training), or any other order than
//     pre_test, training, post_test, retention; a missing training or
//     post_test; a phase given twice;
//   - a retention delay (retention.min_gap_h) that does not exceed the
//     training span: (training.sessions - 1) * training.min_gap_h, the least
//     time the training phase can take;
//   - a stratification attribute that some participant lacks.
// A group that ends up without participants after randomization is refused
// by assign_groups (group_assignment.h), which validate_protocol runs too.

#include <string>

#include "protocols/protocol.h"

namespace hapticlab::protocols {

void validate_transfer_design(const Protocol& protocol, const std::string& source);

// The least time the training phase can take, hours:
// (sessions - 1) * min_gap_h of the training phase (0 without one).
double training_span_h(const TransferDesign& design);

}  // namespace hapticlab::protocols
