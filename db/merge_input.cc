// Opens and checks the site files of a merge (merge_input.h).
#include "db/merge_input.h"

#include <sys/stat.h>

#include "core/common/sha256.h"
#include "db/schema.h"
#include "db/structure_check.h"
#include "db/study_digests.h"
#include "db/study_merge.h"

namespace hapticlab::db::merge {
namespace fs = std::filesystem;

namespace {

// The oldest input schema read as it is: version 8 differs from 9 only by
// session.site, 9 from 10 by session.rate_Hz and participant_model (read
// as NULL: merge_input.h), 10 from 11 by setting.parameters_sha256 (none
// to check; the merged file gets its settings' digests). Older files have
// other checksums; they are migrated first by any command that opens them
// read-write (the merge writes no input).
constexpr int kOldestInputVersion = 8;

void check_structure(Input& in) {
  Database& db = *in.db;
  std::vector<std::string> problems;
  {
    Statement s = db.prepare("PRAGMA integrity_check(20)");
    while (s.step())
      if (const std::string line = s.column_text(0); line != "ok") problems.push_back(line);
  }
  std::vector<Finding> found = check_tables(db, in.version);
  if (found.empty()) {
    std::vector<Finding> more = check_foreign_keys(db, std::size_t{20});
    found.insert(found.end(), more.begin(), more.end());
    // Every version a merge reads: a value of the wrong type in an older
    // file would be copied as a number (a text 'nan' event time as 0.0).
    more = check_value_types(db, std::size_t{20}, in.version);
    found.insert(found.end(), more.begin(), more.end());
  }
  for (const Finding& f : found) problems.push_back(f.message);
  if (problems.empty()) return;
  std::string list;
  for (std::size_t i = 0; i < problems.size() && i < 5; ++i) list += "\n  " + problems[i];
  throw MergeError(in.path.string() + ": damaged site file, refused (`hapticlab study check --db " + in.path.string() +
                   "` lists everything):" + list);
}

}  // namespace

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

std::optional<std::pair<dev_t, ino_t>> file_id(const fs::path& p) {
  struct stat st {};
  if (::stat(p.c_str(), &st) != 0) return std::nullopt;
  return std::make_pair(st.st_dev, st.st_ino);
}

// The site's settings, each checked against its digest (version 11 on).
void read_settings(Input& in) {
  Statement s = in.db->prepare(std::string("SELECT id, name, parameters_json, ") +
                               (in.version >= 11 ? "parameters_sha256" : "NULL") + " FROM setting ORDER BY id");
  while (s.step()) {
    in.settings.push_back({s.column_int64(0), s.column_text(1), s.column_text(2)});
    // A site file older than version 11 has no digest to compare: its
    // settings are compared across the sites' files only.
    if (s.is_null(3)) continue;
    if (const std::string found = sha256_hex(in.settings.back().json); found != s.column_text(3))
      throw MergeError(in.path.string() + ": " +
                       edited_setting_message(s.column_int64(0), s.column_text(1), s.column_text(3), found));
  }
}

void open_input(Input& in) {
  if (!fs::is_regular_file(in.path))
    throw MergeError(in.path.string() + ": " + (fs::exists(in.path) ? "is not a file" : "does not exist") +
                     "; give the site's study file");
  in.db = std::make_unique<Database>(in.path, Database::Mode::kReadOnly);
  Database& db = *in.db;
  try {
    in.version = check_schema_version(db);
  } catch (const DbError& e) {
    throw MergeError(std::string(e.what()) + "; refused as a site file");
  }
  if (in.version < kOldestInputVersion)
    throw MergeError(in.path.string() + ": schema version " + std::to_string(in.version) +
                     " is older than a merge reads (" + std::to_string(kOldestInputVersion) + ".." +
                     std::to_string(kSchemaVersion) + "); migrate it first with a command that opens it read-write "
                     "(`hapticlab analyze --db " + in.path.string() + " --out DIR`), then merge");
  // One snapshot of the file for the whole merge, even if a station writes.
  db.exec("BEGIN");
  check_structure(in);
  {
    Statement s = db.prepare(
        "SELECT name, protocol_json, protocol_sha256, seed, software_version, created_utc FROM study ORDER BY id");
    int n = 0;
    while (s.step()) {
      if (++n > 1) break;
      in.study_name = s.column_text(0);
      in.protocol_json = s.column_text(1);
      in.protocol_sha256 = s.column_text(2);
      in.seed = s.column_text(3);
      in.software_version = s.column_text(4);
      in.created_utc = s.column_text(5);
    }
    if (n != 1)
      throw MergeError(in.path.string() + ": holds " + (n == 0 ? "no study" : "more than one study") +
                       "; a site file holds the one study made by `hapticlab study create`");
  }
  if (sha256_hex(in.protocol_json) != in.protocol_sha256)
    throw MergeError(in.path.string() + ": the stored protocol text does not match its stored SHA-256 (" +
                     in.protocol_sha256 + "): the file was edited or is damaged; refused");
  {
    Statement s = db.prepare(
        "SELECT p.id, p.code, (SELECT count(*) FROM session WHERE participant_id = p.id) FROM participant p ORDER BY p.id");
    while (s.step())
      in.participants.push_back({s.column_int64(0), s.column_text(1), static_cast<int>(s.column_int64(2))});
  }
  read_settings(in);
  // A session still open, or a trial still running: a station is running
  // it, or one was killed and never recovered. Its rows are not final.
  {
    Statement s = db.prepare(
        "SELECT p.code, s.id, (SELECT min(t.id) FROM trial t WHERE t.session_id = s.id AND t.status = 'running') "
        "FROM session s JOIN participant p ON p.id = s.participant_id WHERE s.status = 'open' "
        "UNION ALL SELECT p.code, t.session_id, t.id FROM trial t JOIN participant p ON p.id = t.participant_id "
        "WHERE t.status = 'running' LIMIT 1");
    if (s.step())
      throw MergeError(in.path.string() + ": participant '" + s.column_text(0) + "' has " +
                       (s.is_null(2) ? "session " + std::to_string(s.column_int64(1)) + " still open"
                                     : "trial " + std::to_string(s.column_int64(2)) + " still running") +
                       ": a session runs there, or one was killed and not recovered; let it end, or recover it "
                       "(`hapticlab session run --db " + in.path.string() + " --participant " + s.column_text(0) +
                       "` resumes it), then merge");
  }
  {
    Statement s = db.prepare("SELECT count(*) FROM session WHERE " + in.site_expr() + " IS NULL");
    s.step();
    in.has_unsited_sessions = s.column_int64(0) > 0;
  }
  if (in.version >= 9) {
    Statement s = db.prepare("SELECT DISTINCT site FROM session WHERE site IS NOT NULL");
    while (s.step()) in.stamped_sites.insert(s.column_text(0));
  }
}

}  // namespace hapticlab::db::merge
