#include "app/study_command.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/common/build_info.h"
#include "db/chunk_reader.h"
#include "db/schema.h"
#include "db/study_db.h"
#include "sessions/study_progress.h"
#include "sessions/study_setup.h"

namespace hapticlab::app {
namespace {

struct StudyOptions {
  std::string protocol;
  std::string db;
  bool json = false;
  bool summary = false;
};

void create(const StudyOptions& opt) {
  const std::filesystem::path db_path(opt.db);
  const bool existed = std::filesystem::exists(db_path);
  try {
    db::StudyDb db(db_path);
    const sessions::CreatedStudy created = sessions::create_study(db, opt.protocol, software_version());
    std::printf("created study %lld in %s: %d participants, %d planned trials\n",
                static_cast<long long>(created.study_id), opt.db.c_str(), created.participants, created.trials);
    if (created.external_ve)
      std::printf("next: hapticlab study show --db %s; the lab's application runs the trials through the study API "
                  "(hapticlab/study.h, docs/ve_events.md)\n",
                  opt.db.c_str());
    else
      std::printf("next: hapticlab study show --db %s   or   hapticlab session run --db %s --participant CODE\n",
                  opt.db.c_str(), opt.db.c_str());
  } catch (...) {
    // Leave no half-made file behind: a refused protocol must not block
    // the next attempt with "already holds a study".
    if (!existed) {
      std::error_code ignored;
      for (const char* suffix : {"", "-wal", "-shm"})
        std::filesystem::remove(db_path.string() + suffix, ignored);
    }
    throw;
  }
}

void show(const StudyOptions& opt) {
  if (!std::filesystem::exists(opt.db)) throw std::runtime_error(opt.db + ": no such database");
  db::OpenOptions open;
  open.read_only = true;  // a session may be running: change nothing, not even the journal mode
  open.integrity = db::OpenOptions::Integrity::kFull;  // quick_check misses a damaged index
  db::StudyDb db(opt.db, open);
  const sessions::StudyProgress progress = sessions::study_progress(db);
  if (opt.json) {
    std::printf("%s\n", sessions::study_progress_json(progress).dump(2).c_str());
  } else {
    std::fputs(sessions::format_study_progress(progress, !opt.summary).c_str(), stdout);
  }
}

// `study check`: SQLite's integrity_check, then every chunk's checksum. On a
// plain read-only connection, not StudyDb: StudyDb refuses a damaged file
// at the door, and this command's job is to say what is damaged.
void check(const StudyOptions& opt) {
  if (!std::filesystem::is_regular_file(opt.db))
    throw std::runtime_error("--db: '" + opt.db + "' " +
                             (std::filesystem::exists(opt.db) ? "is not a file" : "does not exist") +
                             "; give a study database made by `hapticlab study create`");
  db::Database conn(opt.db, db::Database::Mode::kReadOnly);

  std::vector<std::string> findings;
  try {
    db::Statement s = conn.prepare("PRAGMA integrity_check(100)");
    while (s.step())
      if (const std::string line = s.column_text(0); line != "ok") findings.push_back(line);
  } catch (const db::DbError& e) {
    findings.push_back(std::string("integrity_check itself failed: ") + e.what());
  }

  // Checksums need the current schema (version 4 added them); a file that
  // SQLite cannot even read gets no further.
  std::string schema_problem;
  db::ChunkCheck chunks;
  try {
    const int version = db::check_schema_version(conn);
    // Version 4 added the checksums; later versions keep them.
    constexpr int kChecksumVersion = 4;
    if (version < kChecksumVersion)
      schema_problem = "schema version " + std::to_string(version) + " has no chunk checksums (version " +
                       std::to_string(kChecksumVersion) + " adds them); a command that opens it read-write "
                       "(`hapticlab analyze`) migrates it, then check again";
    else
      chunks = db::check_all_chunks(conn);
  } catch (const db::DbError& e) {
    schema_problem = e.what();
  }

  const bool damaged = !findings.empty() || !chunks.bad.empty() || !schema_problem.empty();
  if (opt.json) {
    nlohmann::json j;
    j["db"] = opt.db;
    j["integrity_check"] = findings;  // empty: "ok"
    j["chunks_checked"] = chunks.chunks;
    j["updates_checked"] = chunks.updates;
    j["migrated_chunks"] = chunks.migrated_chunks;
    nlohmann::json bad = nlohmann::json::array();
    for (const db::BadChunk& c : chunks.bad)
      bad.push_back({{"trial_id", c.trial_id},
                     {"instrument", c.instrument},
                     {"first_tick", c.first_tick},
                     {"count", c.count},
                     {"problem", c.problem}});
    j["bad_chunks"] = bad;
    if (!schema_problem.empty()) j["error"] = schema_problem;
    j["ok"] = !damaged;
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("%s\n", opt.db.c_str());
    if (findings.empty()) {
      std::printf("  integrity_check: ok\n");
    } else {
      std::printf("  integrity_check: %zu finding(s)\n", findings.size());
      for (const std::string& f : findings) std::printf("    %s\n", f.c_str());
    }
    if (!schema_problem.empty()) {
      std::printf("  sample chunks: not checked: %s\n", schema_problem.c_str());
    } else {
      std::printf("  sample chunks: %llu checked, %zu damaged; %llu updates read back\n",
                  static_cast<unsigned long long>(chunks.chunks), chunks.bad.size(),
                  static_cast<unsigned long long>(chunks.updates));
      if (chunks.migrated_chunks > 0)
        std::printf("    %llu chunk(s) predate checksums: checksummed when the file was migrated, so damage "
                    "done before that cannot be seen\n",
                    static_cast<unsigned long long>(chunks.migrated_chunks));
      for (const db::BadChunk& c : chunks.bad) std::printf("    damaged: %s\n", db::describe(c).c_str());
    }
  }
  std::fflush(stdout);
  if (!findings.empty() || !chunks.bad.empty())
    throw std::runtime_error(opt.db + ": damaged: " + std::to_string(findings.size()) +
                             " integrity_check finding(s), " + std::to_string(chunks.bad.size()) +
                             " damaged sample chunk(s)" + (schema_problem.empty() ? "" : ", chunks not checked"));
  if (damaged) throw std::runtime_error(opt.db + ": sample chunks not checked: " + schema_problem);
  if (!opt.json) std::printf("no damage found\n");
}

}  // namespace

void add_study_command(CLI::App& app) {
  CLI::App* study = app.add_subcommand("study", "Create a study from a protocol file and show its progress");
  study->require_subcommand(1);
  auto opt = std::make_shared<StudyOptions>();

  CLI::App* c = study->add_subcommand(
      "create",
      "Validate a protocol file (docs/protocols.md), plan the design and the block-randomized schedules, "
      "and store the protocol, the full settings and every planned trial in a new study database "
      "before any trial runs.");
  c->add_option("--protocol", opt->protocol, "Protocol JSON file (examples/protocols/*.json)")
      ->required()
      ->check(CLI::ExistingFile);
  c->add_option("--db", opt->db, "Study database to create (SQLite); must not already hold a study")->required();
  c->callback([opt] { create(*opt); });

  CLI::App* s = study->add_subcommand(
      "show", "Print the study, the full schedule with each trial's status, and each participant's progress. "
              "Operator view: names the settings. Safe while a session runs.");
  s->add_option("--db", opt->db, "Study database")->required();
  s->add_flag("--json", opt->json, "Machine-readable output: study, participants, trials with status");
  s->add_flag("--summary", opt->summary, "Only the study and each participant's progress, without the schedule");
  s->callback([opt] { show(*opt); });

  CLI::App* k = study->add_subcommand(
      "check", "Look for damage: SQLite's integrity_check (pages, indexes) plus every sample chunk's checksum. "
               "Prints a summary naming each damaged chunk's trial, instrument and ticks; exit status 1 if "
               "anything is damaged, 0 if not. Read-only.");
  k->add_option("--db", opt->db, "Study database")->required();
  k->add_flag("--json", opt->json, "Machine-readable summary");
  k->callback([opt] { check(*opt); });
}

}  // namespace hapticlab::app
