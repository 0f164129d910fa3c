#pragma once
// What a study's protocol fixes about the haptic loop's protections for
// every trial of the study (docs/safety.md): the force limits of its
// "safety" object and its rate tolerance; the rest of LoopSafetyConfig
// at its defaults. Every runner of the study's trials — session run, the
// console's free trial, plan power for every design — takes its
// SimTrialConfig::safety from here, so that none of them can leave one out
// (a transfer design's plan once left out the force limits, the console's
// free trial the rate tolerance).

#include <string>
#include <string_view>

#include "core/loop/haptic_loop.h"
#include "protocols/protocol.h"

namespace hapticlab::protocols {

LoopSafetyConfig loop_protections(const Protocol& protocol);
// The same from a protocol text a study stored (validated when the study
// was created); ProtocolError naming `source` when it does not read.
LoopSafetyConfig loop_protections_from_protocol_text(std::string_view protocol_json, const std::string& source);

}  // namespace hapticlab::protocols
