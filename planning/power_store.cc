#include "planning/power_store.h"

#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

namespace hapticlab::planning {

PowerStore::PowerStore(const std::filesystem::path& path, const std::string& inputs) : db_(path) {
  db_.exec("PRAGMA journal_mode = WAL");
  db_.exec(
      "CREATE TABLE IF NOT EXISTS run (inputs TEXT NOT NULL);"
      "CREATE TABLE IF NOT EXISTS study (participants INTEGER NOT NULL, idx INTEGER NOT NULL, seed TEXT NOT NULL,"
      " trials_run INTEGER NOT NULL, trials_timed_out INTEGER NOT NULL, updates INTEGER NOT NULL,"
      " seconds REAL NOT NULL, PRIMARY KEY (participants, idx));"
      "CREATE TABLE IF NOT EXISTS finding (participants INTEGER NOT NULL, idx INTEGER NOT NULL,"
      " method TEXT NOT NULL, task TEXT NOT NULL, setting TEXT NOT NULL, measure TEXT NOT NULL,"
      " participant TEXT NOT NULL, p REAL, significant INTEGER NOT NULL,"
      " FOREIGN KEY (participants, idx) REFERENCES study (participants, idx));"
      "CREATE TABLE IF NOT EXISTS staircase (participants INTEGER NOT NULL, idx INTEGER NOT NULL,"
      " participant TEXT NOT NULL, threshold REAL, trials INTEGER NOT NULL,"
      " FOREIGN KEY (participants, idx) REFERENCES study (participants, idx));"
      "CREATE TABLE IF NOT EXISTS setting_change (participants INTEGER NOT NULL, idx INTEGER NOT NULL,"
      " task TEXT NOT NULL, setting TEXT NOT NULL, measure TEXT NOT NULL, n INTEGER NOT NULL, ratio REAL NOT NULL,"
      " FOREIGN KEY (participants, idx) REFERENCES study (participants, idx));"
      "CREATE TABLE IF NOT EXISTS setting_trials (participants INTEGER NOT NULL, idx INTEGER NOT NULL,"
      " task TEXT NOT NULL, setting TEXT NOT NULL, run INTEGER NOT NULL, timed_out INTEGER NOT NULL,"
      " FOREIGN KEY (participants, idx) REFERENCES study (participants, idx));");
  db::Statement q = db_.prepare("SELECT inputs FROM run");
  if (q.step()) {
    const std::string stored = q.column_text(0);
    if (stored != inputs) {
      throw std::runtime_error(path.string() + " holds the studies of another plan (" + stored +
                               "); this one is (" + inputs + "): use another --out, or delete that folder");
    }
  } else {
    db_.prepare("INSERT INTO run (inputs) VALUES (?1)").bind(1, inputs).run();
  }
}

std::set<std::pair<int, int>> PowerStore::done() {
  std::set<std::pair<int, int>> out;
  db::Statement q = db_.prepare("SELECT participants, idx FROM study");
  while (q.step()) out.insert({static_cast<int>(q.column_int64(0)), static_cast<int>(q.column_int64(1))});
  return out;
}

std::vector<StudyOutcome> PowerStore::load() {
  std::map<std::pair<int, int>, StudyOutcome> by_key;
  db::Statement s = db_.prepare(
      "SELECT participants, idx, seed, trials_run, trials_timed_out, updates, seconds FROM study "
      "ORDER BY participants, idx");
  while (s.step()) {
    StudyOutcome o;
    o.participants = static_cast<int>(s.column_int64(0));
    o.index = static_cast<int>(s.column_int64(1));
    o.seed = std::stoull(s.column_text(2));
    o.trials_run = static_cast<int>(s.column_int64(3));
    o.trials_timed_out = static_cast<int>(s.column_int64(4));
    o.updates = static_cast<std::uint64_t>(s.column_int64(5));
    o.seconds = s.column_double(6);
    by_key[{o.participants, o.index}] = std::move(o);
  }
  db::Statement f = db_.prepare(
      "SELECT participants, idx, method, task, setting, measure, participant, p, significant FROM finding "
      "ORDER BY rowid");
  while (f.step()) {
    Finding x;
    x.method = f.column_text(2);
    x.task = f.column_text(3);
    x.setting = f.column_text(4);
    x.measure = f.column_text(5);
    x.participant = f.column_text(6);
    x.p = f.is_null(7) ? std::numeric_limits<double>::quiet_NaN() : f.column_double(7);
    x.significant = f.column_int64(8) != 0;
    by_key.at({static_cast<int>(f.column_int64(0)), static_cast<int>(f.column_int64(1))})
        .findings.push_back(std::move(x));
  }
  db::Statement st = db_.prepare("SELECT participants, idx, participant, threshold, trials FROM staircase ORDER BY rowid");
  while (st.step()) {
    StaircaseOutcome x;
    x.participant = st.column_text(2);
    if (!st.is_null(3)) x.threshold = st.column_double(3);
    x.trials = static_cast<int>(st.column_int64(4));
    by_key.at({static_cast<int>(st.column_int64(0)), static_cast<int>(st.column_int64(1))})
        .staircases.push_back(std::move(x));
  }
  db::Statement ch =
      db_.prepare("SELECT participants, idx, task, setting, measure, n, ratio FROM setting_change ORDER BY rowid");
  while (ch.step()) {
    ChangeOutcome x;
    x.task = ch.column_text(2);
    x.setting = ch.column_text(3);
    x.measure = ch.column_text(4);
    x.participants = static_cast<int>(ch.column_int64(5));
    x.ratio = ch.column_double(6);
    by_key.at({static_cast<int>(ch.column_int64(0)), static_cast<int>(ch.column_int64(1))})
        .changes.push_back(std::move(x));
  }
  db::Statement tr =
      db_.prepare("SELECT participants, idx, task, setting, run, timed_out FROM setting_trials ORDER BY rowid");
  while (tr.step()) {
    SettingTrials x;
    x.task = tr.column_text(2);
    x.setting = tr.column_text(3);
    x.run = static_cast<int>(tr.column_int64(4));
    x.timed_out = static_cast<int>(tr.column_int64(5));
    by_key.at({static_cast<int>(tr.column_int64(0)), static_cast<int>(tr.column_int64(1))})
        .setting_trials.push_back(std::move(x));
  }
  std::vector<StudyOutcome> out;
  for (auto& [key, o] : by_key) out.push_back(std::move(o));
  return out;
}

void PowerStore::add(const StudyOutcome& o) {
  db::Transaction tx(db_);
  db_.prepare(
         "INSERT INTO study (participants, idx, seed, trials_run, trials_timed_out, updates, seconds) "
         "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)")
      .bind(1, std::int64_t{o.participants})
      .bind(2, std::int64_t{o.index})
      .bind(3, std::to_string(o.seed))  // a u64 seed does not fit SQLite's signed integer
      .bind(4, std::int64_t{o.trials_run})
      .bind(5, std::int64_t{o.trials_timed_out})
      .bind(6, static_cast<std::int64_t>(o.updates))
      .bind(7, o.seconds)
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
