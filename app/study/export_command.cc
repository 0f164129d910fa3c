#include "app/study/export_command.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/cli/cli_checks.h"
#include "db/export_csv.h"
#include "db/sample_codec.h"
#include "db/study_db.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;

struct ExportOptions {
  std::string db;
  std::optional<std::int64_t> trial;
  std::string format;
  std::string out;
  std::vector<std::string> channels;
  std::vector<std::string> participants, settings, statuses;
  db::ExportSelection selection;
};

// "--channels": every name must be a channel; the message lists them.
std::string all_channel_names() {
  std::string names;
  for (const char* n : db::kChannelNames) names += (names.empty() ? "" : ", ") + std::string(n);
  return names;
}

// "1..12", or the ids listed when they are not contiguous (re-queued
// trials and several studies leave gaps only rarely; a short list helps).
std::string trial_range(const std::vector<db::TrialRow>& trials) {
  if (trials.empty()) return "the database holds no trials";
  std::int64_t lo = trials.front().id, hi = lo;
  for (const db::TrialRow& t : trials) {
    lo = std::min(lo, t.id);
    hi = std::max(hi, t.id);
  }
  if (static_cast<std::size_t>(hi - lo + 1) == trials.size())
    return "trial ids are " + std::to_string(lo) + ".." + std::to_string(hi);
  std::string ids;
  for (const db::TrialRow& t : trials) ids += (ids.empty() ? "" : ", ") + std::to_string(t.id);
  return "trial ids are " + ids;
}

// The study file, read-only and fully checked.
db::OpenOptions export_open_options() {
  // Read-only and no recovery: exporting must not abort a trial that a
  // session is running right now, nor migrate someone's file.
  db::OpenOptions options;
  options.read_only = true;
  options.recover = false;
  // Full check: quick_check does not compare indexes with their tables, and
  // a damaged index silently hides rows from the queries that use it. The
  // extra cost is small: a chunk row holds ~1000 updates, so there are few
  // rows to look up.
  options.integrity = db::OpenOptions::Integrity::kFull;
  return options;
}

// The options' selection, refused when it mixes --trial with a study's
// selection or names a participant or setting the study does not hold.
db::ExportSelection export_selection(const ExportOptions& opt, db::StudyDb& db) {
  db::ExportSelection selection = opt.selection;
  for (const std::string& name : opt.channels) {
    const std::size_t channel = *db::channel_index(name);
    // Twice would be two columns of one name, which a reader keyed by name
    // takes as one.
    if (std::find(selection.channels.begin(), selection.channels.end(), channel) != selection.channels.end())
      throw CLI::ValidationError("--channels", "'" + name + "' is given twice; each channel is one column");
    selection.channels.push_back(channel);
  }
  selection.participants.insert(opt.participants.begin(), opt.participants.end());
  selection.settings.insert(opt.settings.begin(), opt.settings.end());
  selection.statuses.insert(opt.statuses.begin(), opt.statuses.end());
  if (opt.trial && (!selection.participants.empty() || !selection.settings.empty() || !selection.statuses.empty() ||
                    selection.one_file))
    throw CLI::ValidationError("--trial", "exports one trial; --participant, --setting, --status and --one-file "
                                          "select from a whole study: give one or the other");
  // A selection naming nothing in the study is a typo, not an empty export.
  auto check_names = [&](const std::set<std::string>& wanted, const char* option, auto field) {
    std::set<std::string> known;
    for (const db::TrialRow& t : db.trials()) known.insert(field(t));
    for (const std::string& w : wanted) {
      if (known.count(w)) continue;
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + ("'" + k + "'");
      throw CLI::ValidationError(option, "'" + w + "' is not in " + opt.db + "; it holds: " + list);
    }
  };
  check_names(selection.participants, "--participant", [](const db::TrialRow& t) { return t.participant_code; });
  check_names(selection.settings, "--setting", [](const db::TrialRow& t) { return t.setting_name; });
  return selection;
}

// The files of --trial, or of every study in the file.
std::vector<fs::path> export_files(const ExportOptions& opt, db::StudyDb& db, const db::ExportSelection& selection,
                                   std::vector<db::BadChunk>& bad) {
  std::vector<fs::path> files;
  if (opt.trial) {
    const std::vector<db::TrialRow> trials = db.trials();
    const auto it = std::find_if(trials.begin(), trials.end(), [&](const db::TrialRow& t) { return t.id == *opt.trial; });
    if (it == trials.end())
      throw std::runtime_error("--trial: no trial " + std::to_string(*opt.trial) + " in " + opt.db + "; " +
                               trial_range(trials));
    if (it->status == db::TrialStatus::kPlanned)
      throw std::runtime_error("--trial: trial " + std::to_string(*opt.trial) + " in " + opt.db +
                               " is planned: it has not run, so it has no samples or events to export");
    return db::export_trial_csv(db, *opt.trial, opt.out, &bad, selection);
  }
  const std::vector<db::StudyRow> studies = db.studies();
  if (studies.empty())
    throw std::runtime_error("--db: " + opt.db + " holds no study (run `hapticlab study create` first)");
  for (const db::StudyRow& s : studies) {
    // One study per file is the rule; should there be more, each gets a
    // folder so their trials.csv do not overwrite each other.
    const fs::path dir = studies.size() == 1 ? fs::path(opt.out) : fs::path(opt.out) / ("study" + std::to_string(s.id));
    const std::vector<fs::path> written = db::export_study_csv(db, s.id, dir, &bad, selection);
    files.insert(files.end(), written.begin(), written.end());
  }
  return files;
}

void run_export(const ExportOptions& opt) {
  if (opt.format != "csv")
    throw std::runtime_error("--format: '" + opt.format + "' is not a supported format; allowed: csv");
  if (!fs::is_regular_file(opt.db))
    throw std::runtime_error("--db: '" + opt.db + "' " +
                             (fs::exists(opt.db) ? "is not a file" : "does not exist") +
                             "; give a study database made by `hapticlab study create`");
  db::StudyDb db(opt.db, export_open_options());
  std::vector<db::BadChunk> bad;
  const db::ExportSelection selection = export_selection(opt, db);
  const std::vector<fs::path> files = export_files(opt, db, selection, bad);
  std::printf("%s: exported %s as csv: %zu files in %s\n", opt.db.c_str(),
              opt.trial ? ("trial " + std::to_string(*opt.trial)).c_str() : "every started trial",
              files.size(), opt.out.c_str());
  std::fflush(stdout);
  // The files hold everything that could be read; the damaged chunks'
  // updates are missing from them, which a script must not miss: exit 1.
  if (!bad.empty()) {
    std::uint64_t updates = 0;
    for (const db::BadChunk& c : bad) {
      std::fprintf(stderr, "warning: left out damaged sample chunk: %s\n", db::describe(c).c_str());
      updates += c.count;
    }
    throw std::runtime_error(opt.db + ": " + std::to_string(bad.size()) + " damaged sample chunk(s) (" +
                             std::to_string(updates) + " updates) left out of the export, listed above; "
                             "`hapticlab study check --db " + opt.db + "` lists every damaged chunk");
  }
}

}  // namespace

void add_export_command(CLI::App& app) {
  auto opt = std::make_shared<ExportOptions>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "Export samples and events from a study database: one trial, or every started trial of the "
      "study plus trials.csv (plan, status, times, loop timing, drops, device counters). Read-only: safe while a "
      "session runs.");
  cmd->add_option("--db", opt->db, "Study database (FILE.db)")->required();
  cmd->add_option("--trial", opt->trial, "Trial id (as in `hapticlab study show`); default: the whole study");
  cmd->add_option("--format", opt->format, "Output format; allowed: csv")->required();
  cmd->add_option("--out", opt->out,
                  "Output folder, created if needed. Per trial <participant>_<task>_<setting>_rep<r>_trial<id>"
                  "_samples.csv (one row per update per instrument, SI units in the column names) and "
                  "_events.csv; each file is written to NAME.tmp and renamed when complete")
      ->required();
  add_list_option(*cmd, "--channels", opt->channels,
                  "Only these sample channels, comma-separated, in this order (default: all): " + all_channel_names(),
                  CLI::Validator(
                      [](std::string& name) {
                        return db::channel_index(name) ? std::string()
                                                       : "'" + name + "' is not a channel; channels: " +
                                                             all_channel_names();
                      },
                      "CHANNEL"));
  cmd->add_option("--every", opt->selection.every,
                  "Keep every N-th update (rows whose tick is a multiple of N; both instruments), N >= 1")
      ->capture_default_str()
      ->check(whole_number_in(1, 1000000));
  cmd->add_option("--participant", opt->participants, "Only this participant's trials (repeatable)");
  cmd->add_option("--setting", opt->settings, "Only trials under this setting name (repeatable)");
  cmd->add_option("--status", opt->statuses, "Only trials with this status (repeatable): complete, aborted, running")
      ->check(CLI::IsMember({"complete", "aborted", "running"}));
  cmd->add_flag("--one-file", opt->selection.one_file,
                "One samples.csv and one events.csv for all the selected trials (beside trials.csv), not a pair "
                "per trial");
  cmd->add_flag("--gzip", opt->selection.gzip, "Write FILE.csv.gz (gzip) instead of FILE.csv");
  cmd->callback([opt] { run_export(*opt); });
}

}  // namespace hapticlab::app
