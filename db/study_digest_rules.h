#pragma once
// The digests a study file keeps of what defines its study: the protocol
// text (study.protocol_sha256, since schema 1) and each setting's
// parameters (setting.parameters_sha256, since schema 11), both SHA-256 of
// the stored text, written with it (by `study create`, by a staircase
// session adding a strength, by `study merge`; an older file's settings get
// theirs at the migration to version 11). A session takes its schedule
// from the one and configures its engine from the other, so an edit made
// with an SQLite shell would change what later participants feel while
// their trials stay in the same comparison. Every reader compares text and
// digest: StudyDb refuses the file at open and the row when it is read (a
// session holds the file open for hours), `study check` lists each one,
// `study merge` refuses the site file, the SQL extension refuses the trials
// of an edited setting or study. No SQLite here: the extension compiles
// these rules in.
//
// The digests find an edit, not a forgery: whoever rewrites a text can
// rewrite its digest too. They are there for the operator who "fixes" a
// value by hand, which is what happens in a lab.

#include <cstdint>
#include <string>
#include <string_view>

namespace hapticlab::db {

// sha256_hex(text): the digest as it is stored.
std::string text_digest(std::string_view text);

// "setting 'High Fidelity' (id 3): its parameters_json does not match the
// SHA-256 stored with it (...)", without the file name; an empty stored
// digest (a setting a program older than schema 11 wrote into a migrated
// file) is said as such.
std::string edited_setting_message(std::int64_t setting_id, const std::string& name, const std::string& stored_sha256,
                                   const std::string& found_sha256);
std::string edited_protocol_message(std::int64_t study_id, const std::string& stored_sha256,
                                    const std::string& found_sha256);

}  // namespace hapticlab::db
