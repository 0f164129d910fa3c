#pragma once
// The site files a merge reads (study_merge.h): each opened read-only in one
// snapshot and checked before anything is copied, and the digest that finds
// a participant's same sessions in two files.

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "db/sqlite_handle.h"

namespace hapticlab::db::merge {

struct Participant {
  std::int64_t id = 0;
  std::string code;
  int sessions = 0;
};

struct Setting {
  std::int64_t id = 0;
  std::string name;
  std::string json;
};

struct Input {
  std::filesystem::path path;
  std::string site;
  std::size_t index = 0;
  std::unique_ptr<Database> db;
  int version = 0;
  std::string study_name, protocol_json, protocol_sha256, seed, software_version, created_utc;
  std::vector<Participant> participants;  // by id
  std::vector<Setting> settings;          // by id
  bool has_unsited_sessions = false;
  bool site_named = false;  // by --site FILE=NAME (else the file's name)
  std::set<std::string> stamped_sites;  // sites its sessions already carry (an earlier merge's)
  dev_t dev = 0;
  ino_t ino = 0;

  std::string site_expr() const { return version >= 9 ? "site" : "NULL"; }
  // Version 10 added the session's loop rate and participant model (NULL
  // before: not recorded).
  std::string session_conditions_expr() const {
    return version >= 10 ? "rate_Hz, participant_model" : "NULL, NULL";
  }
};

std::string quoted(const std::filesystem::path& p);

// The file's device and inode (nullopt: it cannot be stat'ed).
std::optional<std::pair<dev_t, ino_t>> file_id(const std::filesystem::path& p);

// Opens `in.path` read-only in one transaction (one snapshot for the whole
// merge) and fills `in` after checking it: a study file of schema 8 or 9,
// undamaged, one study whose protocol matches its SHA-256, no session open
// and no trial running. Throws MergeError (DbError for what SQLite cannot
// read) naming the file and the rule.
void open_input(Input& in);

// Everything recorded of one participant in one file, without ids or site:
// two files with the same digest hold the same sessions (a file named
// twice under two names, or a site's file beside an earlier merge of it).
std::string participant_digest(const Input& in, std::int64_t pid);

}  // namespace hapticlab::db::merge
