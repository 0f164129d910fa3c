#include "db/study_digest_rules.h"

#include "core/common/sha256.h"

namespace hapticlab::db {
namespace {

// The first 12 hex digits: enough to tell two digests apart in a message.
std::string short_digest(const std::string& hex) { return hex.size() > 12 ? hex.substr(0, 12) + "..." : "'" + hex + "'"; }

}  // namespace

std::string text_digest(std::string_view text) { return sha256_hex(text); }

std::string edited_setting_message(std::int64_t setting_id, const std::string& name, const std::string& stored_sha256,
                                   const std::string& found_sha256) {
  if (stored_sha256.empty())
    return "setting '" + name + "' (id " + std::to_string(setting_id) +
           "): no SHA-256 is stored with its parameters_json: it was written by a HapticLab older than schema "
           "version 11 into a file already migrated, so what it defines cannot be told from an edit; refused (write "
           "it with this HapticLab, or create a new study)";
  return "setting '" + name + "' (id " + std::to_string(setting_id) +
         "): its parameters_json does not match the SHA-256 stored with it (stored " +
         short_digest(stored_sha256) + ", the text now gives " + short_digest(found_sha256) +
         "): the file was edited or is damaged, and sessions would run with parameters the study did not define; "
         "refused (put the text back from a copy, or create a new study)";
}

std::string edited_protocol_message(std::int64_t study_id, const std::string& stored_sha256,
                                    const std::string& found_sha256) {
  return "study " + std::to_string(study_id) +
         ": its protocol_json does not match the SHA-256 stored with it (stored " +
         short_digest(stored_sha256) + ", the text now gives " + short_digest(found_sha256) +
         "): the file was edited or is damaged, and its schedule, tasks and design cannot be trusted; refused "
         "(put the text back from a copy, or create a new study)";
}

}  // namespace hapticlab::db
