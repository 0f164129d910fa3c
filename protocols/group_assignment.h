#pragma once
// Randomizing participants to the groups of a between-group design
// (transfer_design.h): stratified permuted blocks.
//
// Participants are split into strata by the value of the attribute
// `stratify_by` names (one stratum without it), strata taken in the order
// their first participant appears. Within a stratum, participants in
// protocol order are dealt groups from blocks: each block is every group
// with room left (declared size not yet reached; no size: always room),
// in a freshly shuffled order. So within each stratum the groups' counts
// differ by at most 1 (with equal or no declared sizes), and every prefix
// of a stratum is balanced within one block, which matters when a study
// stops early.
//
// The random stream is "groups" of Protocol::seed (rng.h): the same
// protocol gives the same groups on any platform, and a study's groups are
// reproduced from its stored protocol text, like its schedules.

#include <cstddef>
#include <string>
#include <vector>

#include "protocols/protocol.h"

namespace hapticlab::protocols {

// The group (index into TransferDesign::groups) of every participant, in
// Protocol::participants order. Needs a protocol with `transfer` whose
// groups and attributes are checked (transfer_rules.h). Throws
// ProtocolError naming "groups[i]" when a group ends up without
// participants (fewer participants, or strata too small, for the groups).
std::vector<std::size_t> assign_groups(const Protocol& protocol, const std::string& source);

}  // namespace hapticlab::protocols
