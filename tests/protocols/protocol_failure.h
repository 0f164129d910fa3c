#pragma once
// The protocol tests' shared helpers: the error a protocol document gets
// (the field path and the message, or "(no error)" for both when it reads),
// and the folder of the shipped protocols, which relative paths start from.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "protocols/protocol_error.h"
#include "protocols/protocol_json.h"

namespace hapticlab::protocols::testing {

inline const std::filesystem::path kExampleProtocolsDir =
    std::filesystem::path(HAPTICLAB_SOURCE_DIR) / "examples" / "protocols";

struct Failure {
  std::string field;
  std::string message;
};

inline Failure protocol_failure(const nlohmann::json& j, const std::filesystem::path& base_dir,
                                const std::string& source = "test.json") {
  try {
    protocol_from_json(j, base_dir, source);
  } catch (const ProtocolError& e) {
    return {e.field(), e.what()};
  }
  return {"(no error)", "(no error)"};
}

}  // namespace hapticlab::protocols::testing
