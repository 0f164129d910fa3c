#include "planning/power_store.h"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <tuple>

#include "analysis/stats/pairwise_friedman.h"
#include "analysis/study/study_analysis.h"
#include "core/common/sha256.h"
#include "core/settings/settings_json.h"
#include "planning/simulated_study.h"

namespace hapticlab::planning {

// What a row of this plan may hold.
struct PowerStore::Shape {
  std::set<std::string> tasks;
  std::set<std::string> compared;  // settings compared with the control
  std::set<std::string> settings;  // every setting of the protocol, the control too
  std::string staircase_prefix;    // the staircase's strengths' names begin so ("" : no staircase)
  std::set<std::string> measures;
  std::map<int, std::set<std::string>> codes;  // per participant count
  double alpha = 0.05;
  double sidak_level = 0.05;
  int max_staircase_trials = -1;  // -1: no staircase
};

namespace {

// The plan_power.db layout this code writes (PRAGMA user_version); files
// of version 1 (a "run" table, no record of the settings files) are refused.
constexpr int kPlanStoreVersion = 2;

const char* const kMethods[] = {"pairwise", "participant_pairwise", "participant"};

// A stored text as it may be shown: at most 40 characters, bytes outside
// printable ASCII as \xNN (a damaged row may hold anything).
std::string shown_text(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size() && i < 40; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += hex;
    }
  }
  return s.size() > 40 ? out + "…" : out;
}

std::string hex_double(double x) {
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(std::bit_cast<std::uint64_t>(x)));
  return buf;
}

// Reads one stored row, each column with the type it must have; the first
// that does not is refused with the file, the row and the column.
class RowReader {
 public:
  RowReader(const db::Statement& s, std::string file, std::string row)
      : s_(s), file_(std::move(file)), row_(std::move(row)) {}

  [[noreturn]] void refuse(const std::string& reason) const {
    throw PlanStoreError(file_ + ": " + row_ + ": " + reason +
                         "; the file is damaged or was edited: start a new --out or remove it");
  }
  // Column `c` holds its value, column c + 1 its typeof().
  std::int64_t integer(int c, const char* name, std::int64_t lo, std::int64_t hi) const {
    expect(c, name, "integer");
    const std::int64_t x = s_.column_int64(c);
    if (x < lo || x > hi)
      refuse(std::string("column ") + name + " is " + std::to_string(x) + ", but must be from " + std::to_string(lo) +
             " to " + std::to_string(hi));
    return x;
  }
  std::string text(int c, const char* name) const {
    expect(c, name, "text");
    return s_.column_text(c);
  }
  std::optional<double> real_or_null(int c, const char* name) const {
    if (type(c) == "null") return std::nullopt;
    expect(c, name, "real");
    const double x = s_.column_double(c);
    if (!std::isfinite(x)) refuse(std::string("column ") + name + " is not a finite number");
    return x;
  }
  double real(int c, const char* name) const {
    if (type(c) == "null") refuse(std::string("column ") + name + " is NULL, but must be a number");
    return *real_or_null(c, name);
  }
  const std::string& row() const { return row_; }

 private:
  std::string type(int c) const { return s_.column_text(c + 1); }
  void expect(int c, const char* name, const char* wanted) const {
    const std::string t = type(c);
    if (t != wanted)
      refuse(std::string("column ") + name + " holds " + (t == "null" ? "NULL" : "a " + t) + ", but must hold " +
             (std::string(wanted) == "integer" ? "an " : "a ") + wanted);
  }
  const db::Statement& s_;
  std::string file_;
  std::string row_;
};

std::string study_label(std::int64_t participants, std::int64_t index) {
  return "study of " + std::to_string(participants) + " participants, number " + std::to_string(index);
}

// The file as SQLite reads it and its layout version; true when it is new
// (no table yet). Throws PlanStoreError naming the file.
bool check_file(db::Database& db, const std::string& path) {
  // A file SQLite reads in full, before anything is trusted.
  {
    db::Statement q = db.prepare("PRAGMA quick_check");
    std::string findings;
    while (q.step())
      if (const std::string r = q.column_text(0); r != "ok") findings += (findings.empty() ? "" : "; ") + r;
    if (!findings.empty())
      throw PlanStoreError(path + ": SQLite finds the file damaged (" + findings.substr(0, 400) +
                           "): start a new --out or remove it");
  }
  const std::int64_t version = db.pragma_int("user_version");
  std::int64_t table_count = 0, old_run_tables = 0;
  {
    db::Statement tables = db.prepare("SELECT count(*), sum(name = 'run') FROM sqlite_schema WHERE type = 'table'");
    tables.step();
    table_count = tables.column_int64(0);
    old_run_tables = tables.column_int64(1);
  }
  const bool empty = table_count == 0;
  if (!empty && version != kPlanStoreVersion) {
    throw PlanStoreError(
        path + ": " +
        (old_run_tables > 0
             ? std::string("made by an older HapticLab, which did not record the plan's settings files and options "
                           "with it, so what its studies were made from cannot be checked")
             : "not a plan_power.db of this HapticLab (schema version " + std::to_string(version) + ", expected " +
                   std::to_string(kPlanStoreVersion) + ")") +
        ": start a new --out or remove it");
  }
  return empty;
}

// The plan's record, the one row of table plan.
PlanInputs stored_plan(db::Database& db, const std::string& path) {
  db::Statement q = db.prepare("SELECT inputs, typeof(inputs) FROM plan");
  std::vector<std::string> stored;
  while (q.step()) stored.push_back(q.column_text(1) == "text" ? q.column_text(0) : std::string());
  if (stored.size() != 1)
    throw PlanStoreError(path + ": table plan has " + std::to_string(stored.size()) +
                         " rows, but a plan has one; the file is damaged or was edited: start a new --out or "
                         "remove it");
  try {
    return PlanInputs::from_json(nlohmann::json::parse(stored.front()));
  } catch (const std::exception& e) {
    throw PlanStoreError(path + ": " + e.what() + "; the file is damaged or was edited: start a new --out or "
                         "remove it");
  }
}

}  // namespace

PowerStore::PowerStore(const std::filesystem::path& path, const PlanInputs& inputs,
                       const protocols::Protocol& protocol)
    : db_(path), path_(path.string()), inputs_(inputs), shape_(std::make_unique<Shape>()) {
  // What a row may hold, from the plan.
  Shape& shape = *shape_;
  for (const protocols::Task& t : protocol.tasks) shape.tasks.insert(std::string(protocols::task_name(t)));
  analysis::StudyAnalysis names;
  for (const auto& s : protocol.settings) names.settings.push_back(s.settings.name);
  analysis::AnalysisOptions analysis_options = SimulatedStudyOptions::default_analysis();
  analysis_options.alpha = inputs.alpha;
  analysis::choose_control(names, analysis_options);
  for (const auto& s : names.settings) {
    shape.settings.insert(s);
    if (s != names.control) shape.compared.insert(s);
  }
  for (analysis::Measure m : analysis::kAllMeasures) shape.measures.insert(analysis::measure_column(m));
  for (int n : inputs.participants)
    for (const auto& p : resized_protocol(protocol, n, inputs.seed).participants) shape.codes[n].insert(p.code);
  shape.alpha = inputs.alpha;
  // As the study's analysis judges its comparisons (statistics_tables.cc).
  const std::size_t m = names.settings.empty() ? 0 : names.settings.size() - 1;
  shape.sidak_level = m > 0 ? analysis::sidak_level(inputs.alpha, m) : inputs.alpha;
  if (protocol.staircase) {
    shape.max_staircase_trials = 2 * protocol.staircase->spec.max_trials;
    // dose_setting_name(base, field, strength) without its strength
    const std::string any = dose_setting_name(protocol.staircase->base.settings.name, protocol.staircase->spec.field, 0.0);
    shape.staircase_prefix = any.substr(0, any.rfind(" = ") + 3);
  }
  // The studies' digests are keyed by the plan without the protocol's path:
  // the same protocol given by another path (a Slurm job's working folder,
  // a copy) is the same plan (plan_inputs.h), and its stored studies must
  // not then read as edited.
  nlohmann::json identity = inputs.to_json();
  identity.erase("protocol_file");
  plan_sha256_ = sha256_hex(identity.dump());

  const bool empty = check_file(db_, path_);
  if (empty) {
    db_.exec("PRAGMA journal_mode = WAL");
    db::Transaction tx(db_);
    db_.exec(
        "CREATE TABLE plan (inputs TEXT NOT NULL, sha256 TEXT NOT NULL);"
        "CREATE TABLE study (participants INTEGER NOT NULL, idx INTEGER NOT NULL, seed TEXT NOT NULL,"
        " trials_run INTEGER NOT NULL, trials_timed_out INTEGER NOT NULL, updates INTEGER NOT NULL,"
        " seconds REAL NOT NULL, sha256 TEXT NOT NULL, PRIMARY KEY (participants, idx));"
        "CREATE TABLE finding (participants INTEGER NOT NULL, idx INTEGER NOT NULL,"
        " method TEXT NOT NULL, task TEXT NOT NULL, setting TEXT NOT NULL, measure TEXT NOT NULL,"
        " participant TEXT NOT NULL, p REAL, significant INTEGER NOT NULL,"
        " FOREIGN KEY (participants, idx) REFERENCES study (participants, idx));"
        "CREATE TABLE staircase (participants INTEGER NOT NULL, idx INTEGER NOT NULL,"
        " participant TEXT NOT NULL, threshold REAL, trials INTEGER NOT NULL,"
        " FOREIGN KEY (participants, idx) REFERENCES study (participants, idx));"
        "CREATE TABLE setting_change (participants INTEGER NOT NULL, idx INTEGER NOT NULL,"
        " task TEXT NOT NULL, setting TEXT NOT NULL, measure TEXT NOT NULL, n INTEGER NOT NULL, ratio REAL NOT NULL,"
        " FOREIGN KEY (participants, idx) REFERENCES study (participants, idx));"
        "CREATE TABLE setting_trials (participants INTEGER NOT NULL, idx INTEGER NOT NULL,"
        " task TEXT NOT NULL, setting TEXT NOT NULL, run INTEGER NOT NULL, timed_out INTEGER NOT NULL,"
        " FOREIGN KEY (participants, idx) REFERENCES study (participants, idx));"
        "PRAGMA user_version = 2;");
    db_.prepare("INSERT INTO plan (inputs, sha256) VALUES (?1, ?2)")
        .bind(1, inputs.to_json().dump())
        .bind(2, plan_sha256_)
        .run();
    tx.commit();
    return;
  }
  const PlanInputs was = stored_plan(db_, path_);
  const std::vector<std::string> changed = plan_differences(was, inputs);
  if (!changed.empty()) {
    std::string list;
    for (std::size_t i = 0; i < changed.size(); ++i)
      list += (i == 0 ? "" : i + 1 == changed.size() ? " and " : "; ") + changed[i];
    throw PlanStoreError("the plan in " + path.parent_path().string() + " was made from " + was.describe() + "; " +
                         list + (changed.size() == 1 ? " has" : " have") +
                         " changed (settings are compared as loaded: white space does not count, any value does): start a "
                         "new --out or remove it (its studies would mix two designs in one table)");
  }
  (void)load();  // every stored row, checked before anything is simulated
}

PowerStore::~PowerStore() = default;

PlanInputs PowerStore::read_plan(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) throw PlanStoreError(path.string() + ": no such file");
  db::Database db(path, db::Database::Mode::kReadOnly);
  if (check_file(db, path.string())) throw PlanStoreError(path.string() + ": holds no plan (no table)");
  return stored_plan(db, path.string());
}

std::set<std::pair<int, int>> PowerStore::done() {
  std::set<std::pair<int, int>> out;
  db::Statement q = db_.prepare("SELECT participants, idx FROM study");
  while (q.step()) out.insert({static_cast<int>(q.column_int64(0)), static_cast<int>(q.column_int64(1))});
  return out;
}

std::string PowerStore::digest(const std::string& plan_sha256, const StudyOutcome& o) {
  std::string text = plan_sha256 + "\n" + std::to_string(o.participants) + " " + std::to_string(o.index) + " " +
                     std::to_string(o.seed) + " " + std::to_string(o.trials_run) + " " +
                     std::to_string(o.trials_timed_out) + " " + std::to_string(o.updates) + " " +
                     hex_double(o.seconds) + "\n";
  // Sorted: the rows' order in the file is not part of what they say.
  std::vector<std::string> lines;
  for (const Finding& f : o.findings)
    lines.push_back("f\x1f" + f.method + "\x1f" + f.task + "\x1f" + f.setting + "\x1f" + f.measure + "\x1f" +
                    f.participant + "\x1f" + (std::isnan(f.p) ? std::string("null") : hex_double(f.p)) + "\x1f" +
                    (f.significant ? "1" : "0"));
  for (const StaircaseOutcome& s : o.staircases)
    lines.push_back("s\x1f" + s.participant + "\x1f" + (s.threshold ? hex_double(*s.threshold) : "null") + "\x1f" +
                    std::to_string(s.trials));
  for (const ChangeOutcome& c : o.changes)
    lines.push_back("c\x1f" + c.task + "\x1f" + c.setting + "\x1f" + c.measure + "\x1f" +
                    std::to_string(c.participants) + "\x1f" + hex_double(c.ratio));
  for (const SettingTrials& t : o.setting_trials)
    lines.push_back("t\x1f" + t.task + "\x1f" + t.setting + "\x1f" + std::to_string(t.run) + "\x1f" +
                    std::to_string(t.timed_out));
  std::sort(lines.begin(), lines.end());
  for (const std::string& l : lines) text += l + "\n";
  return sha256_hex(text);
}

// load(), table by table: the stored studies, then the rows that belong to
// them (findings, staircases, changes, trials per setting), then what is
// recomputed rather than trusted.
struct PowerStore::Loading {
  using Key = std::pair<int, int>;
  static constexpr std::int64_t kMaxInt = std::numeric_limits<int>::max();

  PowerStore& store;
  const Shape& shape;
  std::map<Key, StudyOutcome> by_key;
  std::map<Key, std::string> stored_sha;

  void studies();
  StudyOutcome& owner(const RowReader& r);
  void findings();
  void staircases();
  void changes();
  void setting_trials();
  std::vector<StudyOutcome> verified();
  void check_complete() const;
};

void PowerStore::Loading::studies() {
  const PlanInputs& inputs = store.inputs_;
  db::Statement s = store.db_.prepare(
      "SELECT rowid, participants, typeof(participants), idx, typeof(idx), seed, typeof(seed), trials_run, "
      "typeof(trials_run), trials_timed_out, typeof(trials_timed_out), updates, typeof(updates), seconds, "
      "typeof(seconds), sha256, typeof(sha256) FROM study ORDER BY participants, idx");
  while (s.step()) {
    const RowReader r(s, store.path_, "table study, row " + std::to_string(s.column_int64(0)));
    StudyOutcome o;
    o.participants = static_cast<int>(r.integer(1, "participants", 1, 999));
    if (!shape.codes.count(o.participants))
      r.refuse("it is a study of " + std::to_string(o.participants) + " participants, which this plan (--participants " +
               [&] {
                 std::string l;
                 for (int n : inputs.participants) l += (l.empty() ? "" : ",") + std::to_string(n);
                 return l;
               }() + ") does not ask for");
    o.index = static_cast<int>(r.integer(3, "idx", 0, inputs.studies - 1));
    const RowReader rs(s, store.path_, r.row() + " (" + study_label(o.participants, o.index) + ")");
    if (const int shard = inputs.shard_of(o.participants, o.index); shard != inputs.shard)
      rs.refuse("it is a study of shard " + std::to_string(shard) + "/" + std::to_string(inputs.shards) +
                ", not of this run's shard " + std::to_string(inputs.shard) + "/" + std::to_string(inputs.shards));
    const std::string seed = rs.text(5, "seed");
    const std::uint64_t expected_seed = study_seed(inputs.seed, o.participants, o.index);
    if (seed != std::to_string(expected_seed))
      rs.refuse("column seed is '" + shown_text(seed) + "', but this plan's --seed " + std::to_string(inputs.seed) +
                " gives that study the seed " + std::to_string(expected_seed));
    o.seed = expected_seed;
    o.trials_run = static_cast<int>(rs.integer(7, "trials_run", 0, kMaxInt));
    o.trials_timed_out = static_cast<int>(rs.integer(9, "trials_timed_out", 0, o.trials_run));
    o.updates = static_cast<std::uint64_t>(rs.integer(11, "updates", 0, std::numeric_limits<std::int64_t>::max()));
    o.seconds = rs.real(13, "seconds");
    if (o.seconds < 0.0) rs.refuse("column seconds is negative");
    stored_sha[{o.participants, o.index}] = rs.text(15, "sha256");
    by_key[{o.participants, o.index}] = std::move(o);
  }
}

// Each finding and staircase row belongs to a stored study of the plan.
StudyOutcome& PowerStore::Loading::owner(const RowReader& r) {
  const auto n = static_cast<int>(r.integer(1, "participants", 1, 999));
  const auto i = static_cast<int>(r.integer(3, "idx", 0, kMaxInt));
  const auto it = by_key.find({n, i});
  if (it == by_key.end())
    r.refuse("it belongs to the " + study_label(n, i) + ", which has no row in table study (a study "
             "row was deleted, or this row was added)");
  return it->second;
}

void PowerStore::Loading::findings() {
  std::map<Key, std::set<std::tuple<std::string, std::string, std::string, std::string, std::string>>> seen;
  db::Statement f = store.db_.prepare(
      "SELECT rowid, participants, typeof(participants), idx, typeof(idx), method, typeof(method), task, "
      "typeof(task), setting, typeof(setting), measure, typeof(measure), participant, typeof(participant), p, "
      "typeof(p), significant, typeof(significant) FROM finding ORDER BY rowid");
  while (f.step()) {
    const RowReader r(f, store.path_, "table finding, row " + std::to_string(f.column_int64(0)));
    StudyOutcome& o = owner(r);
    Finding x;
    x.method = r.text(5, "method");
    if (std::find(std::begin(kMethods), std::end(kMethods), x.method) == std::end(kMethods))
      r.refuse("column method is '" + shown_text(x.method) + "', but must be pairwise, participant_pairwise or "
               "participant");
    x.task = r.text(7, "task");
    if (!shape.tasks.count(x.task)) r.refuse("column task is '" + shown_text(x.task) + "', not a task of the protocol");
    x.setting = r.text(9, "setting");
    if (x.method == "participant" ? !x.setting.empty() : !shape.compared.count(x.setting))
      r.refuse("column setting is '" + shown_text(x.setting) + "', but must be " +
               (x.method == "participant" ? std::string("empty for a participant's test")
                                          : "one of the settings compared with the control"));
    x.measure = r.text(11, "measure");
    if (!shape.measures.count(x.measure)) r.refuse("column measure is '" + shown_text(x.measure) + "', not a measure");
    x.participant = r.text(13, "participant");
    if (x.method == "participant" ? !shape.codes.at(o.participants).count(x.participant) : !x.participant.empty())
      r.refuse("column participant is '" + shown_text(x.participant) + "', but must be " +
               (x.method == "participant" ? "one of the study's participants" : std::string("empty")));
    const std::optional<double> p = r.real_or_null(15, "p");
    if (p && !(*p >= 0.0 && *p <= 1.0)) r.refuse("column p is " + std::to_string(*p) + ", but a p lies in [0, 1]");
    x.p = p.value_or(std::numeric_limits<double>::quiet_NaN());
    x.significant = r.integer(17, "significant", 0, 1) != 0;
    if (!seen[{o.participants, o.index}].insert({x.method, x.task, x.setting, x.measure, x.participant}).second)
      r.refuse("it repeats a test of its study (" + x.method + ", " + x.task + ", " +
               (x.setting.empty() ? x.participant : x.setting) + ", " + x.measure + ")");
    o.findings.push_back(std::move(x));
  }
}

void PowerStore::Loading::staircases() {
  db::Statement st = store.db_.prepare(
      "SELECT rowid, participants, typeof(participants), idx, typeof(idx), participant, typeof(participant), "
      "threshold, typeof(threshold), trials, typeof(trials) FROM staircase ORDER BY rowid");
  while (st.step()) {
    const RowReader r(st, store.path_, "table staircase, row " + std::to_string(st.column_int64(0)));
    StudyOutcome& o = owner(r);
    if (shape.max_staircase_trials < 0) r.refuse("this plan's protocol has no staircase");
    StaircaseOutcome x;
    x.participant = r.text(5, "participant");
    if (!shape.codes.at(o.participants).count(x.participant))
      r.refuse("column participant is '" + shown_text(x.participant) + "', not one of the study's participants");
    x.threshold = r.real_or_null(7, "threshold");
    x.trials = static_cast<int>(r.integer(9, "trials", 0, shape.max_staircase_trials));
    o.staircases.push_back(std::move(x));
  }
}

// Each setting's change against the control (study_change.h).
void PowerStore::Loading::changes() {
  std::map<Key, std::set<std::tuple<std::string, std::string, std::string>>> seen_change;
  db::Statement ch = store.db_.prepare(
      "SELECT rowid, participants, typeof(participants), idx, typeof(idx), task, typeof(task), setting, "
      "typeof(setting), measure, typeof(measure), n, typeof(n), ratio, typeof(ratio) FROM setting_change "
      "ORDER BY rowid");
  while (ch.step()) {
    const RowReader r(ch, store.path_, "table setting_change, row " + std::to_string(ch.column_int64(0)));
    StudyOutcome& o = owner(r);
    ChangeOutcome x;
    x.task = r.text(5, "task");
    if (!shape.tasks.count(x.task)) r.refuse("column task is '" + shown_text(x.task) + "', not a task of the protocol");
    x.setting = r.text(7, "setting");
    if (!shape.compared.count(x.setting))
      r.refuse("column setting is '" + shown_text(x.setting) + "', but must be one of the settings compared with the "
               "control");
    x.measure = r.text(9, "measure");
    if (!shape.measures.count(x.measure)) r.refuse("column measure is '" + shown_text(x.measure) + "', not a measure");
    x.participants = static_cast<int>(r.integer(11, "n", 1, o.participants));
    x.ratio = r.real(13, "ratio");
    if (!(x.ratio >= 0.0)) r.refuse("column ratio is " + std::to_string(x.ratio) + ", but a ratio of medians is >= 0");
    if (!seen_change[{o.participants, o.index}].insert({x.task, x.setting, x.measure}).second)
      r.refuse("it repeats a change of its study (" + x.task + ", " + x.setting + ", " + x.measure + ")");
    o.changes.push_back(std::move(x));
  }
}

// The trials run and timed out per setting (the comparison report's).
void PowerStore::Loading::setting_trials() {
  std::map<Key, std::set<std::pair<std::string, std::string>>> seen_trials;
  db::Statement tr = store.db_.prepare(
      "SELECT rowid, participants, typeof(participants), idx, typeof(idx), task, typeof(task), setting, "
      "typeof(setting), run, typeof(run), timed_out, typeof(timed_out) FROM setting_trials ORDER BY rowid");
  while (tr.step()) {
    const RowReader r(tr, store.path_, "table setting_trials, row " + std::to_string(tr.column_int64(0)));
    StudyOutcome& o = owner(r);
    SettingTrials x;
    x.task = r.text(5, "task");
    if (!shape.tasks.count(x.task)) r.refuse("column task is '" + shown_text(x.task) + "', not a task of the protocol");
    x.setting = r.text(7, "setting");
    if (!shape.settings.count(x.setting) &&
        (shape.staircase_prefix.empty() || x.setting.rfind(shape.staircase_prefix, 0) != 0))
      r.refuse("column setting is '" + shown_text(x.setting) + "', not a setting of the protocol" +
               (shape.staircase_prefix.empty() ? "" : " or a strength of its staircase"));
    x.run = static_cast<int>(r.integer(9, "run", 0, o.trials_run));
    x.timed_out = static_cast<int>(r.integer(11, "timed_out", 0, x.run));
    if (!seen_trials[{o.participants, o.index}].insert({x.task, x.setting}).second)
      r.refuse("it repeats the trials of its study's " + x.task + " under " + x.setting);
    o.setting_trials.push_back(std::move(x));
  }
}

// Recomputed, not trusted: each test's significance, then each study's digest.
std::vector<StudyOutcome> PowerStore::Loading::verified() {
  std::vector<StudyOutcome> out;
  for (auto& [key, o] : by_key) {
    const std::string where = store.path_ + ": " + study_label(key.first, key.second);
    std::set<std::pair<std::string, std::string>> table34;  // (task, measure) with a participant's test below alpha
    for (const Finding& x : o.findings)
      if (x.method == "participant" && x.p < shape.alpha) table34.insert({x.task, x.measure});
    for (const Finding& x : o.findings) {
      if (std::isnan(x.p)) continue;
      const bool expected = x.method == "participant"            ? x.p < shape.alpha
                            : x.method == "participant_pairwise" ? x.p < shape.sidak_level
                                                                 : x.p < shape.sidak_level &&
                                                                       table34.count({x.task, x.measure}) > 0;
      if (x.significant != expected)
        throw PlanStoreError(where + ": its " + x.method + " test (" + x.task + ", " +
                             (x.setting.empty() ? x.participant : x.setting) + ", " + x.measure + ") is stored as " +
                             (x.significant ? "significant" : "not significant") + ", but its p " +
                             std::to_string(x.p) + " makes it " + (expected ? "significant" : "not significant") +
                             "; the file is damaged or was edited: start a new --out or remove it");
    }
    if (digest(store.plan_sha256_, o) != stored_sha.at(key))
      throw PlanStoreError(where + ": its rows do not match the SHA-256 stored with it (a finding, staircase or "
                           "count was changed, added or removed after the study was stored); the file is damaged or "
                           "was edited: start a new --out or remove it");
    out.push_back(std::move(o));
  }
  return out;
}

void PowerStore::Loading::check_complete() const {
  const PlanInputs& inputs = store.inputs_;
  const std::vector<std::pair<int, int>> wanted = inputs.studies_of_shard();
  for (const auto& [n, i] : wanted)
    if (!by_key.count({n, i}))
      throw PlanStoreError(store.path_ + ": the " + study_label(n, i) + " is missing" +
                           (inputs.shards > 1 ? " from shard " + std::to_string(inputs.shard) + "/" +
                                                    std::to_string(inputs.shards)
                                              : std::string()) +
                           " (" + std::to_string(by_key.size()) + " of " + std::to_string(wanted.size()) +
                           " studies stored)");
}

std::vector<StudyOutcome> PowerStore::load(bool complete) {
  Loading loading{*this, *shape_, {}, {}};
  loading.studies();
  loading.findings();
  loading.staircases();
  loading.changes();
  loading.setting_trials();
  std::vector<StudyOutcome> out = loading.verified();
  if (complete) loading.check_complete();
  return out;
}

void PowerStore::add(const StudyOutcome& o) {
  db::Transaction tx(db_);
  db_.prepare(
         "INSERT INTO study (participants, idx, seed, trials_run, trials_timed_out, updates, seconds, sha256) "
         "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)")
      .bind(1, std::int64_t{o.participants})
      .bind(2, std::int64_t{o.index})
      .bind(3, std::to_string(o.seed))  // a u64 seed does not fit SQLite's signed integer
      .bind(4, std::int64_t{o.trials_run})
      .bind(5, std::int64_t{o.trials_timed_out})
      .bind(6, static_cast<std::int64_t>(o.updates))
      .bind(7, o.seconds)
      .bind(8, digest(plan_sha256_, o))
      .run();
  db::Statement ins = db_.prepare(
      "INSERT INTO finding (participants, idx, method, task, setting, measure, participant, p, significant) "
      "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)");
  for (const Finding& f : o.findings) {
    ins.reset();
    ins.bind(1, std::int64_t{o.participants}).bind(2, std::int64_t{o.index}).bind(3, f.method).bind(4, f.task);
    ins.bind(5, f.setting).bind(6, f.measure).bind(7, f.participant);
    if (std::isnan(f.p)) ins.bind_null(8); else ins.bind(8, f.p);
    ins.bind(9, std::int64_t{f.significant ? 1 : 0});
    ins.run();
  }
  db::Statement stair = db_.prepare(
      "INSERT INTO staircase (participants, idx, participant, threshold, trials) VALUES (?1, ?2, ?3, ?4, ?5)");
  for (const StaircaseOutcome& s : o.staircases) {
    stair.reset();
    stair.bind(1, std::int64_t{o.participants}).bind(2, std::int64_t{o.index}).bind(3, s.participant);
    if (s.threshold) stair.bind(4, *s.threshold); else stair.bind_null(4);
    stair.bind(5, std::int64_t{s.trials});
    stair.run();
  }
  db::Statement change = db_.prepare(
      "INSERT INTO setting_change (participants, idx, task, setting, measure, n, ratio) "
      "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  for (const ChangeOutcome& c : o.changes) {
    change.reset();
    change.bind(1, std::int64_t{o.participants}).bind(2, std::int64_t{o.index}).bind(3, c.task).bind(4, c.setting);
    change.bind(5, c.measure).bind(6, std::int64_t{c.participants}).bind(7, c.ratio);
    change.run();
  }
  db::Statement trials = db_.prepare(
      "INSERT INTO setting_trials (participants, idx, task, setting, run, timed_out) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
  for (const SettingTrials& t : o.setting_trials) {
    trials.reset();
    trials.bind(1, std::int64_t{o.participants}).bind(2, std::int64_t{o.index}).bind(3, t.task).bind(4, t.setting);
    trials.bind(5, std::int64_t{t.run}).bind(6, std::int64_t{t.timed_out});
    trials.run();
  }
  tx.commit();
}

}  // namespace hapticlab::planning
