#include "app/study/study_command.h"

#include <algorithm>
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
#include "db/structure_check.h"
#include "db/study_check.h"
#include "db/study_db.h"
#include "db/study_merge.h"
#include "sessions/study_progress.h"
#include "sessions/study_setup.h"

namespace hapticlab::app {
namespace {

struct StudyOptions {
  std::string protocol;
  std::string db;
  bool json = false;
  bool summary = false;
  std::vector<std::string> sites;       // study merge: the site files
  std::vector<std::string> site_names;  // study merge: FILE=NAME
  std::string out;
};

void create(const StudyOptions& opt) {
  const std::filesystem::path db_path(opt.db);
  const bool existed = std::filesystem::exists(db_path);
  try {
    db::StudyDb db(db_path);
    const sessions::CreatedStudy created = sessions::create_study(db, opt.protocol, software_version());
    std::printf("created study %lld in %s: %d participants, %d planned trials\n",
                static_cast<long long>(created.study_id), opt.db.c_str(), created.participants, created.trials);
    for (const std::string& name : created.unscheduled_settings)
      std::fprintf(stderr,
                   "hapticlab: warning: setting '%s' is in no participant's schedule (the design gives it no "
                   "trials with these %d participants), so it will not be run; add participants, or leave it out "
                   "of the protocol\n",
                   name.c_str(), created.participants);
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

// `study check` (db/study_check.h finds, this prints).
using StudyCheckFindings = db::StudyFileCheck;

void print_study_check_json(const StudyOptions& opt, const StudyCheckFindings& c, bool damaged) {
  nlohmann::json j;
  j["db"] = opt.db;
  nlohmann::json integrity_lines = nlohmann::json::array();
  for (const db::Finding& f : c.findings)
    if (f.check == "integrity") integrity_lines.push_back(f.message);
  j["integrity_check"] = integrity_lines;  // empty: "ok"
  j["chunks_checked"] = c.chunks.chunks;
  j["updates_checked"] = c.chunks.updates;
  j["migrated_chunks"] = c.chunks.migrated_chunks;
  nlohmann::json bad = nlohmann::json::array();
  for (const db::BadChunk& b : c.chunks.bad)
    bad.push_back({{"trial_id", b.trial_id},
                   {"instrument", b.instrument},
                   {"first_tick", b.first_tick},
                   {"count", b.count},
                   {"kind", db::to_string(b.kind)},
                   {"problem", b.problem}});
  j["bad_chunks"] = bad;
  // Every finding of every check, each naming what it concerns.
  nlohmann::json all = nlohmann::json::array();
  for (const db::Finding& f : c.findings) {
    nlohmann::json x = {{"check", f.check}, {"message", f.message}};
    if (!f.table.empty()) x["table"] = f.table;
    if (f.row) x["row"] = *f.row;
    if (f.trial_id) x["trial_id"] = *f.trial_id;
    if (f.instrument) x["instrument"] = *f.instrument;
    all.push_back(std::move(x));
  }
  j["findings"] = all;
  if (!c.not_checked.empty()) j["error"] = c.not_checked;
  j["ok"] = !damaged;
  std::printf("%s\n", j.dump(2).c_str());
}

// The findings of `checks` under `title`, or "ok".
void print_check_findings(const std::vector<db::Finding>& findings, const char* title,
                          const std::vector<std::string>& checks) {
  std::vector<const db::Finding*> mine;
  for (const db::Finding& f : findings)
    for (const std::string& c : checks)
      if (f.check == c) mine.push_back(&f);
  if (mine.empty()) {
    std::printf("  %s: ok\n", title);
    return;
  }
  std::printf("  %s: %zu finding(s)\n", title, mine.size());
  for (const db::Finding* f : mine) std::printf("    %s\n", f->message.c_str());
}

void print_study_check_text(const StudyOptions& opt, const StudyCheckFindings& c) {
  std::printf("%s\n", opt.db.c_str());
  print_check_findings(c.findings, "integrity_check", {"integrity"});
  if (c.structure > 0 || c.not_checked.empty())
    print_check_findings(c.findings, "structure (tables, references, value types, protocol and setting digests)",
                         {"schema", "foreign_key", "type", "edited"});
  if (!c.not_checked.empty()) {
    std::printf("  sample chunks: not checked: %s\n", c.not_checked.c_str());
    return;
  }
  std::printf("  sample chunks: %llu checked, %zu damaged; %llu updates read back\n",
              static_cast<unsigned long long>(c.chunks.chunks), c.chunks.bad.size(),
              static_cast<unsigned long long>(c.chunks.updates));
  if (c.chunks.migrated_chunks > 0)
    std::printf("    %llu chunk(s) predate checksums: checksummed when the file was migrated, so damage "
                "done before that cannot be seen\n",
                static_cast<unsigned long long>(c.chunks.migrated_chunks));
  for (const db::BadChunk& b : c.chunks.bad) std::printf("    damaged: %s\n", db::describe(b).c_str());
}

void check(const StudyOptions& opt) {
  if (!std::filesystem::is_regular_file(opt.db))
    throw std::runtime_error("--db: '" + opt.db + "' " +
                             (std::filesystem::exists(opt.db) ? "is not a file" : "does not exist") +
                             "; give a study database made by `hapticlab study create`");
  db::Database conn(opt.db, db::Database::Mode::kReadOnly);
  const StudyCheckFindings c = db::check_study_file(conn);
  const bool damaged = c.damaged();
  if (opt.json)
    print_study_check_json(opt, c, damaged);
  else
    print_study_check_text(opt, c);
  std::fflush(stdout);
  if (!c.findings.empty())
    throw std::runtime_error(opt.db + ": damaged: " + std::to_string(c.integrity) + " integrity_check finding(s), " +
                             std::to_string(c.structure) + " structure finding(s), " +
                             std::to_string(c.chunks.bad.size()) + " damaged sample chunk(s)" +
                             (c.not_checked.empty() ? "" : ", chunks not checked"));
  if (damaged) throw std::runtime_error(opt.db + ": sample chunks not checked: " + c.not_checked);
  if (!opt.json) std::printf("no damage found\n");
}

// `study merge`: the site files of one study into one study file
// (db/study_merge.h).
void merge(const StudyOptions& opt) {
  db::MergeOptions m;
  m.out = opt.out;
  std::vector<bool> named(opt.site_names.size(), false);
  for (const std::string& path : opt.sites) {
    db::SiteInput in{path, {}};
    std::size_t named_by = opt.site_names.size();  // the --site that named this file
    for (std::size_t i = 0; i < opt.site_names.size(); ++i) {
      const std::string& given = opt.site_names[i];
      const std::size_t eq = given.find('=');
      if (eq == std::string::npos || eq == 0)
        throw std::runtime_error("--site: '" + given + "' is not FILE=NAME (e.g. --site " + path + "=Basel)");
      // FILE is this input's path as given, up to its '=' (a site name's own
      // '=' is then the name's, for check_site_name to judge).
      if (given.size() <= path.size() || given.compare(0, path.size(), path) != 0 || given[path.size()] != '=')
        continue;
      if (named_by < opt.site_names.size())
        throw std::runtime_error("--site: " + path + " is named twice ('" + opt.site_names[named_by] + "' and '" +
                                 given + "'); give one name per site file");
      in.site = given.substr(path.size() + 1);
      db::check_site_name(in.site, "--site " + given);
      named[i] = true;
      named_by = i;
    }
    m.inputs.push_back(std::move(in));
  }
  for (std::size_t i = 0; i < named.size(); ++i)
    if (!named[i])
      throw std::runtime_error("--site: '" + opt.site_names[i] + "' names no input file (give FILE as in the list of "
                               "site files)");
  const db::MergeResult r = db::merge_sites(m);
  for (const std::string& note : r.notes) std::printf("note: %s\n", note.c_str());
  for (const db::SiteSummary& s : r.sites)
    if (!s.skipped)
      std::printf("  %s: %s, %d participant(s) with sessions, %d session(s)%s\n", s.path.string().c_str(),
                  s.site.empty() ? "an earlier merge (its sessions keep their sites)" : ("site '" + s.site + "'").c_str(),
                  s.participants, s.sessions,
                  s.trials_renumbered > 0
                      ? (", " + std::to_string(s.trials_renumbered) + " trial(s) renumbered, their chunks re-checksummed")
                            .c_str()
                      : "");
  if (r.unchanged)
    std::printf("%s already holds this merge (%d participants, %d sessions, %d trials): unchanged\n", opt.out.c_str(),
                r.participants, r.sessions, r.trials);
  else
    std::printf("merged %zu site file(s) into %s: %d participants, %d sessions, %d trials, %llu sample chunks "
                "verified and copied\n",
                static_cast<std::size_t>(
                    std::count_if(r.sites.begin(), r.sites.end(), [](const db::SiteSummary& s) { return !s.skipped; })),
                opt.out.c_str(), r.participants, r.sessions, r.trials, static_cast<unsigned long long>(r.chunks));
}

}  // namespace

void add_study_command(CLI::App& app) {
  CLI::App* study = app.add_subcommand("study", "Create a study from a protocol file, show its progress, check it for damage, merge the site files of a multi-site study");
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
      "check", "Look for damage: SQLite's integrity_check (pages, indexes); the tables, references and value "
               "types the schema says; every sample chunk's place (instrument, ticks, no overlap), checksum and "
               "structure. Prints every finding, naming the table, row, trial and instrument; exit status 1 if "
               "anything is damaged, 0 if not. Read-only.");
  k->add_option("--db", opt->db, "Study database")->required();
  k->add_flag("--json", opt->json, "Machine-readable summary");
  k->callback([opt] { check(*opt); });

  CLI::App* m = study->add_subcommand(
      "merge",
      "Merge the site files of one multi-site study into one study file (docs/protocols.md, \"Multi-site studies\"): the same protocol "
      "(by its SHA-256), each participant's sessions from one file, every sample chunk verified before it is "
      "copied, each session stamped with its site. The merged file is an ordinary study (analyze, export, study "
      "check, sim replay, the Python reader and the SQL extension read it). Written to a temporary file next to "
      "--out, synced, then renamed: --out is complete or as it was. Merging the same files again changes nothing.");
  m->add_option("sites", opt->sites, "Site study files (each from `hapticlab study create` with the same protocol)")
      ->required();
  m->add_option("--out", opt->out,
                "The merged study file: new, or an earlier merge of the same study (brought up to date; refused if "
                "it holds sessions no input has); never one of the inputs")
      ->required();
  m->add_option("--site", opt->site_names,
                "FILE=NAME: the site name for FILE's sessions (repeatable; default: the file name without .db)");
  m->callback([opt] { merge(*opt); });
}

}  // namespace hapticlab::app
