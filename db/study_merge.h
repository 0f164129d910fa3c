#pragma once
// Merging the site files of one multi-site study into one study file
// (`hapticlab study merge`, issue 36 §4; db/README.md "Multi-site merges").
//
// Each site (a station in one hospital) runs its participants into its own
// study file, created from the same protocol. The merge reads them all
// read-only and writes a new file that is an ordinary study (schema 9,
// every reader accepts it), each session stamped with its site:
//
//   inputs ─► checks (protocol hash, schema, no live session, settings,
//             each participant's sessions in one file) ─► a temporary file
//             next to --out (built in one transaction, every chunk verified
//             before it is copied) ─► fsync ─► rename over --out ─► fsync dir
//
// A participant's rows all come from the one input that holds their
// sessions. Ids: setting, participant and trial rows keep their input's id
// when it is free (the site files of a study share the planned trials' ids,
// so a merged trial has the id it had at its site, and the same trial run
// in one file); a trial added at a site (a re-queued copy, a staircase step)
// whose id another site used gets the next free id, and its chunks are
// verified under the old id and re-checksummed under the new one
// (sample_codec.h move_chunk). Sessions, training, events and the other
// rows are numbered anew in a fixed order (sessions by start time), so the
// same inputs always make the same file.

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace hapticlab::db {

// A refusal or a stop of the merge; the message names the file, the row
// and the rule. Nothing was written to --out (it is as it was).
class MergeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct SiteInput {
  std::filesystem::path path;
  // The site's name for its sessions that have none yet (a site's own
  // file); sessions of an earlier merge keep theirs. Empty: the file
  // name's stem ("site_a" for site_a.db). 1..64 printable characters.
  std::string site;
};

struct MergeOptions {
  std::vector<SiteInput> inputs;  // at least one
  // The merged study. It may exist only as a previous merge of the same
  // study whose sessions are all among the inputs' (it is then brought up
  // to date, or left untouched when nothing changed); never as an input.
  std::filesystem::path out;
};

struct SiteSummary {
  std::filesystem::path path;
  std::string site;          // the name given to its sessions without one; empty when all had one (a merge)
  int participants = 0;      // participants whose sessions come from it
  int sessions = 0;
  int trials_renumbered = 0;  // trials given a new id (their chunks re-checksummed)
  bool skipped = false;       // the same file as an earlier input: read once
};

struct MergeResult {
  std::vector<SiteSummary> sites;
  std::vector<std::string> notes;  // participants found identical in two files, ...
  int participants = 0;            // in the study
  int sessions = 0;
  int trials = 0;
  std::uint64_t chunks = 0;  // verified and copied
  bool unchanged = false;    // --out already held exactly this merge: not rewritten
};

// Validates a site name (1..64 characters, no control characters, no
// leading or trailing space); throws MergeError naming it and the rule.
void check_site_name(const std::string& name, const std::string& what);

// Merges; throws MergeError (or DbError for an input SQLite cannot read)
// naming what was refused and why. On any failure, including a full disk,
// the temporary file is removed, --out is as it was and no input is written.
MergeResult merge_sites(const MergeOptions& options);

}  // namespace hapticlab::db
