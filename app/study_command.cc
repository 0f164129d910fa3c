#include "app/study_command.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

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
    const sessions::CreatedStudy created = sessions::create_study(db, opt.protocol, HAPTICLAB_VERSION_STRING);
    std::printf("created study %lld in %s: %d participants, %d planned trials\n",
                static_cast<long long>(created.study_id), opt.db.c_str(), created.participants, created.trials);
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
  open.integrity = db::OpenOptions::Integrity::kQuick;
  db::StudyDb db(opt.db, open);
  const sessions::StudyProgress progress = sessions::study_progress(db);
  if (opt.json) {
    std::printf("%s\n", sessions::study_progress_json(progress).dump(2).c_str());
  } else {
    std::fputs(sessions::format_study_progress(progress, !opt.summary).c_str(), stdout);
  }
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
}

}  // namespace hapticlab::app
