#pragma once
// Protocol files (JSON): read and validate. Format: docs/protocols.md.
//
// Every field is checked when the file is read; unknown fields are errors
// (a typo must never silently fall back to a default), and every error is a
// ProtocolError naming the field's path, the value and the rule. Settings
// given as paths are resolved relative to the protocol file's directory and
// loaded in full; a settings file that fails to load is reported with the
// protocol field and the SettingsError's message.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

#include "protocols/protocol.h"
#include "protocols/protocol_error.h"

namespace hapticlab::protocols {

// `base_dir` resolves relative settings paths; `source` names the origin in
// error messages.
Protocol protocol_from_json(const nlohmann::json& j, const std::filesystem::path& base_dir,
                            const std::string& source);
Protocol protocol_from_json_text(std::string_view text, const std::filesystem::path& base_dir,
                                 const std::string& source);
Protocol load_protocol_file(const std::filesystem::path& path);
// The "staircase" rule of a protocol text a study stored (validated when
// the study was created; its settings are in the database, not read here);
// nullopt when it has none. ProtocolError when the block does not read.
std::optional<StaircaseSpec> staircase_from_protocol_text(std::string_view text, const std::string& source);
// The group design of a protocol text a study stored (transfer_design.h):
// a Protocol with its study, tasks, participants, `transfer` and seed, but
// no settings (those are in the database); nullopt when it has no groups.
// Enough for assign_groups and group_sittings. ProtocolError when it does
// not read.
std::optional<Protocol> group_design_from_protocol_text(std::string_view text, const std::string& source);
// The "rate_tolerance_fraction" of a protocol text a study stored; the
// default (RateCheck::kDefaultToleranceFraction) when it has none.
double rate_tolerance_from_protocol_text(std::string_view text, const std::string& source);
// The protocol file's text, within the size cap of JSON inputs (what a
// study stores byte for byte); ProtocolError naming the file otherwise.
std::string read_protocol_text(const std::filesystem::path& path);

}  // namespace hapticlab::protocols
