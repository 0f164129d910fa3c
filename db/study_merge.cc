#include "db/study_merge.h"

#include <fcntl.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <map>
#include <optional>
#include <utility>

#include "db/merge_copy.h"
#include "db/merge_input.h"
#include "db/schema.h"
#include "db/schema_shape.h"

namespace hapticlab::db {
namespace fs = std::filesystem;

namespace {

using merge::file_id;
using merge::Input;
using merge::Participant;
using merge::quoted;

// A write to the temporary file failed: a full disk says so plainly.
[[noreturn]] void storage_stop(const fs::path& temp, const fs::path& out, const std::string& cause, bool existed) {
  throw MergeError("study merge stopped: cannot write " + quoted(temp) + ": " + cause + "; the temporary file is "
                   "removed, " + quoted(out) + (existed ? " is as it was" : " was not created") +
                   " and the inputs are untouched; free space (or choose --out on another disk), then run the same "
                   "merge again");
}

std::string sqlite_cause(const DbError& e) {
  const int primary = e.sqlite_code() & 0xff;
  if (primary == SQLITE_FULL) return "the disk is full (" + std::string(e.what()) + ")";
  return e.what();
}

void fsync_path(const fs::path& p, bool directory) {
  const int fd = ::open(p.c_str(), directory ? O_RDONLY | O_DIRECTORY : O_RDONLY);
  if (fd < 0) throw std::runtime_error("cannot open " + quoted(p) + " to sync it: " + std::strerror(errno));
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) throw std::runtime_error("cannot sync " + quoted(p) + ": " + std::strerror(err));
}

void remove_temp(const fs::path& temp) {
  std::error_code ignored;
  for (const char* suffix : {"", "-journal", "-wal", "-shm"}) fs::remove(temp.string() + suffix, ignored);
}

// Temporary files of earlier merges into the same --out whose process is
// gone (killed mid-merge): never renamed, so nobody will; removed.
void remove_stale_temps(const fs::path& dir, const std::string& out_name) {
  const std::string prefix = "." + out_name + ".merge-";
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (!name.starts_with(prefix)) continue;
    const std::size_t end = name.find(".tmp", prefix.size());
    if (end == std::string::npos) continue;
    long pid = 0;
    const auto [ptr, err] = std::from_chars(name.data() + prefix.size(), name.data() + end, pid);
    if (err != std::errc() || ptr != name.data() + end || pid <= 0) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to judge
    fs::remove(e.path(), ec);
  }
}

// True when every row of every table is the same in both files.
bool same_content(Database& built, const fs::path& existing) {
  Statement attach = built.prepare("ATTACH DATABASE ?1 AS old");
  attach.bind(1, existing.string()).run();
  bool same = true;
  for (const TableShape& t : schema_tables()) {
    const std::string name = t.name;
    Statement s = built.prepare("SELECT (SELECT count(*) FROM main." + name + ") = (SELECT count(*) FROM old." + name +
                                ") AND NOT EXISTS (SELECT * FROM main." + name + " EXCEPT SELECT * FROM old." + name +
                                ")");
    s.step();
    if (s.column_int64(0) == 0) {
      same = false;
      break;
    }
  }
  built.exec("DETACH DATABASE old");
  return same;
}

// An existing --out: a previous merge of this study, whose sessions the new
// merge all has (by participant, start time and site); anything else is
// refused, naming what would be lost or overwritten.
void check_existing_out(const fs::path& out, const Input& first, Database& built) {
  Database old(out, Database::Mode::kReadOnly);
  int version = 0;
  try {
    version = check_schema_version(old);
  } catch (const DbError& e) {
    throw MergeError("--out " + quoted(out) + " exists and is not a merged study of this HapticLab (" + e.what() +
                     "); a merge replaces only an earlier merge of the same study: give a new --out");
  }
  if (version != kSchemaVersion)
    throw MergeError("--out " + quoted(out) + " exists at schema version " + std::to_string(version) +
                     ", so it is not an earlier merge of this HapticLab (merges write version " +
                     std::to_string(kSchemaVersion) + "; an older HapticLab's merge is not replaced); give a new --out");
  {
    Statement s = old.prepare("SELECT protocol_sha256 FROM study");
    if (!s.step() || s.column_text(0) != first.protocol_sha256)
      throw MergeError("--out " + quoted(out) + " exists and holds another study (protocol SHA-256 " +
                       (s.is_null(0) ? std::string("none") : s.column_text(0)) + ", the inputs' is " +
                       first.protocol_sha256 + "); give a new --out");
  }
  {
    Statement s = old.prepare("SELECT count(*) FROM session WHERE site IS NULL");
    s.step();
    if (s.column_int64(0) > 0)
      throw MergeError("--out " + quoted(out) + " holds " + std::to_string(s.column_int64(0)) +
                       " session(s) recorded in it (no site): it is a site's own file, not an earlier merge, and a "
                       "merge never overwrites one; give a new --out");
  }
  Statement attach = built.prepare("ATTACH DATABASE ?1 AS old");
  attach.bind(1, out.string()).run();
  std::string lost;
  int n = 0;
  std::string renamed;  // a site the inputs hold under another name
  {
    // The fourth column: the site the inputs give the same session (same
    // participant and start), if they hold it under another name.
    Statement s = built.prepare(
        "SELECT p.code, s.site, count(*), (SELECT m.site FROM main.session m JOIN main.participant q ON "
        "q.id = m.participant_id WHERE q.code = p.code AND m.started_unix_s = s.started_unix_s LIMIT 1) "
        "FROM old.session s JOIN old.participant p ON p.id = s.participant_id "
        "WHERE NOT EXISTS (SELECT 1 FROM main.session m JOIN main.participant q ON q.id = m.participant_id "
        "WHERE q.code = p.code AND m.started_unix_s = s.started_unix_s AND m.site = s.site) "
        "GROUP BY p.code, s.site ORDER BY p.code");
    while (s.step()) {
      const bool now_named = !s.is_null(3);
      if (now_named && renamed.empty())
        renamed = "; a site renamed? --out calls it '" + s.column_text(1) + "', the inputs '" + s.column_text(3) +
                  "': keep the earlier name (--site FILE=" + s.column_text(1) + ") or give a new --out";
      if (n++ < 5)
        lost += std::string(lost.empty() ? "" : ", ") + "participant '" + s.column_text(0) + "' (" +
                std::to_string(s.column_int64(2)) + " session(s) of site '" + s.column_text(1) + "'" +
                (now_named ? ", which the inputs hold as site '" + s.column_text(3) + "'" : std::string()) + ")";
    }
  }
  built.exec("DETACH DATABASE old");
  if (n > 0)
    throw MergeError("--out " + quoted(out) + " is an earlier merge holding sessions none of the inputs has: " + lost +
                     (renamed.empty() ? "; replacing it would lose them: add that site's file to the inputs, or give "
                                        "a new --out"
                                      : renamed));
}

using FileId = std::pair<dev_t, ino_t>;

// The inputs opened and checked (merge_input.h), each file once; a file
// given twice is noted and skipped. Every input gets its summary in
// `result.sites`, in the order given.
std::vector<Input> open_inputs(const MergeOptions& options, const std::optional<FileId>& out_id, MergeResult& result) {
  std::vector<Input> inputs;
  std::vector<FileId> seen;
  for (const SiteInput& given : options.inputs) {
    SiteSummary summary;
    summary.path = given.path;
    const std::optional<FileId> id = file_id(given.path);
    if (id && out_id && *id == *out_id)
      throw MergeError("--out " + quoted(options.out) + " is the input " + quoted(given.path) +
                       " (the same file): a merge never writes onto one of its own inputs; give a new --out");
    if (id && std::find(seen.begin(), seen.end(), *id) != seen.end()) {
      summary.skipped = true;
      result.notes.push_back(given.path.string() + ": the same file as an earlier input; read once");
      result.sites.push_back(summary);
      continue;
    }
    Input in;
    in.path = given.path;
    in.site = given.site.empty() ? given.path.stem().string() : given.site;
    in.site_named = !given.site.empty();
    check_site_name(in.site, given.path.string());
    in.index = inputs.size();
    merge::open_input(in);
    if (id) {
      in.dev = id->first;
      in.ino = id->second;
      seen.push_back(*id);
    }
    bool any_session = false;
    for (const Participant& p : in.participants) any_session = any_session || p.sessions > 0;
    if (in.has_unsited_sessions || !any_session) summary.site = in.site;
    result.sites.push_back(summary);
    inputs.push_back(std::move(in));
  }
  return inputs;
}

// One study (the same protocol text, by its hash), and no two site files
// sharing a site name for their own sessions.
void check_one_study(const std::vector<Input>& inputs) {
  for (const Input& in : inputs)
    if (in.protocol_sha256 != inputs.front().protocol_sha256)
      throw MergeError("different protocols: " + inputs.front().path.string() + " holds study '" +
                       inputs.front().study_name + "' (protocol SHA-256 " + inputs.front().protocol_sha256 + "), " +
                       in.path.string() + " study '" + in.study_name + "' (protocol SHA-256 " + in.protocol_sha256 +
                       "); only site files of one study (the same protocol file) merge");
  for (std::size_t a = 0; a < inputs.size(); ++a)
    for (std::size_t b = a + 1; b < inputs.size(); ++b)
      if (inputs[a].has_unsited_sessions && inputs[b].has_unsited_sessions && inputs[a].site == inputs[b].site)
        throw MergeError(inputs[a].path.string() + " and " + inputs[b].path.string() + " would both be site '" +
                         inputs[a].site + "'; name each with --site FILE=NAME");
  // A file's own sessions named after its file like sessions another file
  // already carries from an earlier merge: the same station, or two under
  // one name; only the operator knows, and says it with --site.
  for (const Input& own : inputs)
    for (const Input& other : inputs)
      if (&own != &other && own.has_unsited_sessions && !own.site_named && other.stamped_sites.contains(own.site))
        throw MergeError(own.path.string() + "'s own sessions would be site '" + own.site + "' (its file's name), but " +
                         other.path.string() + " already holds sessions of site '" + own.site +
                         "' from an earlier merge: if they are one station, say so with --site " + own.path.string() +
                         "=" + own.site + "; if not, give it another name");
}

// Each participant's sessions from one file (code -> input); a file
// identical in a participant's rows to another (the same file twice)
// counts once.
std::map<std::string, std::size_t> choose_sources(const std::vector<Input>& inputs, MergeResult& result) {
  std::map<std::string, std::size_t> source;  // code -> input
  std::map<std::string, std::string> digest;
  for (const Input& in : inputs)
    for (const Participant& p : in.participants) {
      if (p.sessions == 0) {
        source.try_emplace(p.code, in.index);
        continue;
      }
      const auto it = source.find(p.code);
      const bool taken = it != source.end() && digest.contains(p.code);
      if (!taken) {
        source[p.code] = in.index;
        digest[p.code] = "";  // computed on demand below
        continue;
      }
      const Input& other = inputs[it->second];
      const Participant* q = nullptr;
      for (const Participant& x : other.participants)
        if (x.code == p.code) q = &x;
      if (digest[p.code].empty()) digest[p.code] = merge::participant_digest(other, q->id);
      if (merge::participant_digest(in, p.id) == digest[p.code]) {
        result.notes.push_back("participant '" + p.code + "': the same " + std::to_string(p.sessions) +
                               " session(s) in " + other.path.string() + " and " + in.path.string() + "; taken once");
        continue;
      }
      throw MergeError("participant '" + p.code + "' has sessions in two files: " + other.path.string() + " (" +
                       std::to_string(q->sessions) + ") and " + in.path.string() + " (" + std::to_string(p.sessions) +
                       "), with different data; a participant's sessions must all come from one site's file");
    }
  return source;
}

// Builds the merged study in `temp` (one transaction), checks its
// references, and compares it with an existing --out; true when --out
// already holds exactly this merge.
bool build_merged(const fs::path& temp, const MergeOptions& options, bool out_exists, std::vector<Input>& inputs,
                  const Input& first, const std::map<std::string, std::size_t>& source, MergeResult& result) {
  Database out(temp);
  out.exec("PRAGMA journal_mode = DELETE");
  out.exec("PRAGMA synchronous = FULL");
  migrate(out);
  out.exec("PRAGMA foreign_keys = ON");
  Transaction tx(out);
  merge::copy_study(inputs, first, source, out, result);
  tx.commit();
  {
    Statement s = out.prepare("PRAGMA foreign_key_check");
    if (s.step())
      throw MergeError("internal: the merged file has a broken reference (table " + s.column_text(0) + " row " +
                       std::to_string(s.column_int64(1)) + "); nothing written");
  }
  if (!out_exists) return false;
  check_existing_out(options.out, first, out);
  return same_content(out, options.out);
}

// The built file synced and renamed over --out, then its folder synced.
void replace_out(const fs::path& temp, const fs::path& out, const fs::path& dir, bool out_exists) {
  fsync_path(temp, false);
  if (out_exists) {
    // The old file's WAL, if a reader left one, belongs to the old file:
    // folded back into it first, so the renamed file is never read with it.
    Database old(out, Database::Mode::kReadWrite);
    old.exec("PRAGMA journal_mode = DELETE");
  }
  if (::rename(temp.c_str(), out.c_str()) != 0)
    throw std::runtime_error("cannot rename " + quoted(temp) + " to " + quoted(out) + ": " + std::strerror(errno));
  fsync_path(dir, true);
}

}  // namespace

void check_site_name(const std::string& name, const std::string& what) {
  bool printable = true;
  for (unsigned char c : name)
    if (c < 0x20 || c == 0x7f) printable = false;
  if (name.empty() || name.size() > 64 || !printable || name.front() == ' ' || name.back() == ' ')
    throw MergeError(what + ": site name '" + name + "' must be 1..64 characters, with no control characters and "
                     "no leading or trailing space");
}

MergeResult merge_sites(const MergeOptions& options) {
  if (options.inputs.empty()) throw MergeError("study merge: give at least one site file");
  if (options.out.empty()) throw MergeError("study merge: --out is required");
  if (const fs::path parent = options.out.parent_path(); !parent.empty() && !fs::is_directory(parent))
    throw MergeError("--out " + quoted(options.out) + ": the folder " + quoted(parent) + " does not exist");
  const bool out_exists = fs::exists(options.out);
  const std::optional<FileId> out_id = out_exists ? file_id(options.out) : std::nullopt;
  if (out_exists && !fs::is_regular_file(options.out))
    throw MergeError("--out " + quoted(options.out) + " exists and is not a file");

  MergeResult result;
  std::vector<Input> inputs = open_inputs(options, out_id, result);
  check_one_study(inputs);
  const std::map<std::string, std::size_t> source = choose_sources(inputs, result);

  // The study row: the earliest created (then the first given), so the
  // order of the inputs does not change it.
  const Input* first = &inputs.front();
  for (const Input& in : inputs)
    if (in.created_utc < first->created_utc) first = &in;

  // Built next to --out (the same file system, so the rename is atomic).
  const fs::path dir = options.out.has_parent_path() ? options.out.parent_path() : fs::path(".");
  const fs::path temp = dir / ("." + options.out.filename().string() + ".merge-" + std::to_string(::getpid()) + ".tmp");
  remove_stale_temps(dir, options.out.filename().string());
  remove_temp(temp);
  try {
    result.unchanged = build_merged(temp, options, out_exists, inputs, *first, source, result);
    if (result.unchanged) {
      remove_temp(temp);
      return result;
    }
    replace_out(temp, options.out, dir, out_exists);
  } catch (const MergeError&) {
    remove_temp(temp);
    throw;
  } catch (const DbError& e) {
    remove_temp(temp);
    const int primary = e.sqlite_code() & 0xff;
    if (primary == SQLITE_FULL || primary == SQLITE_IOERR || primary == SQLITE_CANTOPEN)
      storage_stop(temp, options.out, sqlite_cause(e), out_exists);
    throw MergeError(std::string("study merge stopped: ") + e.what() + "; " + quoted(options.out) +
                     (out_exists ? " is as it was" : " was not created") + " and the inputs are untouched");
  } catch (const std::exception& e) {
    remove_temp(temp);
    storage_stop(temp, options.out, e.what(), out_exists);
  }
  return result;
}

}  // namespace hapticlab::db
