// Copies the rows of a merge's site files into the merged study
// (merge_copy.h): the study, settings and participants by name and code,
// then sessions, training, trials with their verified chunks, and the
// operator's actions.
#include "db/merge_copy.h"

#include <algorithm>
#include <map>
#include <optional>
#include <set>
#include <tuple>
#include <utility>

#include "core/common/sha256.h"
#include "db/chunk_coverage.h"
#include "db/chunk_layout.h"
#include "db/chunk_reader.h"
#include "db/sample_codec.h"

namespace hapticlab::db::merge {

namespace {

// Where a trial of the output comes from.
struct TrialSource {
  std::size_t input = 0;
  std::int64_t id = 0;      // in the input
  std::int64_t out_id = 0;  // in the output
  std::int64_t participant_out = 0;
};

struct SessionSource {
  std::size_t input = 0;
  std::int64_t id = 0;
  double started_unix_s = 0.0;
  std::string site;
};

class Builder {
 public:
  Builder(std::vector<Input>& inputs, Database& out) : inputs_(inputs), out_(out) {}

  void study(const Input& in) {
    Statement s = out_.prepare(
        "INSERT INTO study (id, name, protocol_json, protocol_sha256, seed, software_version, created_utc) "
        "VALUES (1, ?1, ?2, ?3, ?4, ?5, ?6)");
    s.bind(1, in.study_name).bind(2, in.protocol_json).bind(3, in.protocol_sha256).bind(4, in.seed);
    s.bind(5, in.software_version).bind(6, in.created_utc).run();
  }

  // Settings by name: the same name must mean the same parameters.
  void settings() {
    std::map<std::string, std::pair<std::int64_t, const Input*>> by_name;
    std::set<std::int64_t> used;
    std::vector<std::pair<const Setting*, const Input*>> pending;
    for (const Input& in : inputs_)
      for (const Setting& st : in.settings) {
        auto it = by_name.find(st.name);
        if (it != by_name.end()) {
          const Setting& first = setting_of(*it->second.second, st.name);
          if (first.json != st.json)
            throw MergeError("setting '" + st.name + "' has other parameters in " + in.path.string() + " than in " +
                             it->second.second->path.string() + ": sites of one study must use the same settings");
          setting_map_[{in.index, st.id}] = it->second.first;
          continue;
        }
        by_name[st.name] = {0, &in};
        pending.emplace_back(&st, &in);
      }
    for (auto& [st, in] : pending)
      if (used.insert(st->id).second) by_name[st->name].first = st->id;
    std::int64_t next = used.empty() ? 1 : *used.rbegin() + 1;
    for (auto& [st, in] : pending)
      if (by_name[st->name].first == 0) by_name[st->name].first = next++;
    // Inserted in id order; every input's row mapped.
    std::vector<std::tuple<std::int64_t, std::string, std::string>> rows;
    for (auto& [st, in] : pending) rows.emplace_back(by_name[st->name].first, st->name, st->json);
    std::sort(rows.begin(), rows.end());
    Statement ins = out_.prepare(
        "INSERT INTO setting (id, study_id, name, parameters_json, parameters_sha256) VALUES (?1, 1, ?2, ?3, ?4)");
    for (const auto& [id, name, json] : rows) {
      ins.reset();
      ins.bind(1, id).bind(2, name).bind(3, json).bind(4, sha256_hex(json)).run();
    }
    for (const Input& in : inputs_)
      for (const Setting& st : in.settings) setting_map_[{in.index, st.id}] = by_name[st.name].first;
  }

  // Participants by code, each taken from `source[code]`.
  void participants(const std::map<std::string, std::size_t>& source) {
    std::map<std::string, std::int64_t> ids;
    std::set<std::int64_t> used;
    std::vector<std::pair<std::string, std::int64_t>> wanted;  // code, id in its first input
    for (const Input& in : inputs_)
      for (const Participant& p : in.participants)
        if (!ids.contains(p.code)) {
          ids[p.code] = 0;
          wanted.emplace_back(p.code, p.id);
        }
    for (auto& [code, id] : wanted)
      if (used.insert(id).second) ids[code] = id;
    std::int64_t next = used.empty() ? 1 : *used.rbegin() + 1;
    for (auto& [code, id] : wanted)
      if (ids[code] == 0) ids[code] = next++;
    std::vector<std::pair<std::int64_t, std::string>> rows;
    for (const auto& [code, id] : ids) rows.emplace_back(id, code);
    std::sort(rows.begin(), rows.end());
    Statement ins = out_.prepare("INSERT INTO participant (id, study_id, code) VALUES (?1, 1, ?2)");
    for (const auto& [id, code] : rows) {
      ins.reset();
      ins.bind(1, id).bind(2, code).run();
      const Input& in = inputs_[source.at(code)];
      for (const Participant& p : in.participants)
        if (p.code == code) chosen_.push_back({in.index, p.id, id});
    }
  }

  // Sessions, training, trials and everything hanging off them.
  void rows(MergeResult& result) {
    collect();
    // Sessions: numbered by start time (then input order), with their site.
    Statement ins_session = out_.prepare(
        "INSERT INTO session (id, participant_id, started_unix_s, ended_unix_s, device, clock, status, site, "
        "rate_Hz, participant_model) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)");
    for (std::size_t k = 0; k < sessions_.size(); ++k) {
      const SessionSource& src = sessions_[k];
      const std::int64_t out_id = static_cast<std::int64_t>(k + 1);
      session_map_[{src.input, src.id}] = out_id;
      Input& in = inputs_[src.input];
      Statement s = in.db->prepare("SELECT participant_id, started_unix_s, ended_unix_s, device, clock, status, " +
                                   in.session_conditions_expr() + " FROM session WHERE id = ?1");
      s.bind(1, src.id);
      s.step();
      ins_session.reset();
      ins_session.bind(1, out_id).bind(2, participant_map_.at({src.input, s.column_int64(0)}));
      ins_session.bind(3, s.column_double(1));
      if (s.is_null(2)) ins_session.bind_null(4);
      else ins_session.bind(4, s.column_double(2));
      ins_session.bind(5, s.column_text(3)).bind(6, s.column_text(4)).bind(7, s.column_text(5)).bind(8, src.site);
      if (s.is_null(6)) ins_session.bind_null(9);
      else ins_session.bind(9, s.column_double(6));
      if (s.is_null(7)) ins_session.bind_null(10);
      else ins_session.bind(10, s.column_text(7));
      ins_session.run();
      ++summary(src.input).sessions;
    }
    result.sessions = static_cast<int>(sessions_.size());
    // Training, by session.
    Statement ins_training = out_.prepare(
        "INSERT INTO training (session_id, task, started_unix_s, ended_unix_s, duration_s, trials, cut_short, "
        "cut_short_reason) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)");
    for (const SessionSource& src : sessions_) {
      Statement s = inputs_[src.input].db->prepare(
          "SELECT task, started_unix_s, ended_unix_s, duration_s, trials, cut_short, cut_short_reason FROM training "
          "WHERE session_id = ?1 ORDER BY id");
      s.bind(1, src.id);
      while (s.step()) {
        ins_training.reset();
        ins_training.bind(1, session_map_.at({src.input, src.id})).bind(2, s.column_text(0)).bind(3, s.column_double(1));
        copy_real(ins_training, 4, s, 2);
        copy_real(ins_training, 5, s, 3);
        ins_training.bind(6, s.column_int64(4)).bind(7, s.column_int64(5));
        if (s.is_null(6)) ins_training.bind_null(8);
        else ins_training.bind(8, s.column_text(6));
        ins_training.run();
      }
    }
    trials(result);
    operator_actions();
  }

  std::map<std::size_t, SiteSummary*> summaries;

 private:
  struct Chosen {
    std::size_t input;
    std::int64_t id;      // in the input
    std::int64_t out_id;  // in the output
  };

  SiteSummary& summary(std::size_t input) { return *summaries.at(input); }

  static const Setting& setting_of(const Input& in, const std::string& name) {
    for (const Setting& s : in.settings)
      if (s.name == name) return s;
    throw MergeError("internal: setting '" + name + "' vanished from " + in.path.string());
  }

  static void copy_real(Statement& to, int param, const Statement& from, int column) {
    if (from.is_null(column)) to.bind_null(param);
    else to.bind(param, from.column_double(column));
  }

  void collect() {
    for (const Chosen& c : chosen_) {
      participant_map_[{c.input, c.id}] = c.out_id;
      Input& in = inputs_[c.input];
      Statement s = in.db->prepare("SELECT id, started_unix_s, " + in.site_expr() +
                                   " FROM session WHERE participant_id = ?1 ORDER BY id");
      s.bind(1, c.id);
      while (s.step())
        sessions_.push_back({c.input, s.column_int64(0), s.column_double(1), s.is_null(2) ? in.site : s.column_text(2)});
      Statement t = in.db->prepare("SELECT id FROM trial WHERE participant_id = ?1 ORDER BY id");
      t.bind(1, c.id);
      while (t.step()) trials_.push_back({c.input, t.column_int64(0), 0, c.out_id});
    }
    std::stable_sort(sessions_.begin(), sessions_.end(), [](const SessionSource& a, const SessionSource& b) {
      return std::tie(a.started_unix_s, a.input, a.id) < std::tie(b.started_unix_s, b.input, b.id);
    });
    // A trial keeps its id when no trial before it (participant order) took it.
    std::set<std::int64_t> used;
    for (TrialSource& t : trials_)
      if (used.insert(t.id).second) t.out_id = t.id;
    std::int64_t next = used.empty() ? 1 : *used.rbegin() + 1;
    for (TrialSource& t : trials_)
      if (t.out_id == 0) {
        t.out_id = next++;
        ++summary(t.input).trials_renumbered;
      }
    for (const TrialSource& t : trials_) trial_map_[{t.input, t.id}] = t.out_id;
    std::sort(trials_.begin(), trials_.end(), [](const TrialSource& a, const TrialSource& b) { return a.out_id < b.out_id; });
  }

  void trials(MergeResult& result) {
    trial_rows();
    result.trials = static_cast<int>(trials_.size());
    TrialInserts ins(out_);
    for (const TrialSource& t : trials_) {
      Input& in = inputs_[t.input];
      copy_chunks(t, in, ins.chunk, result);
      copy_events(t, *in.db, ins.event);
      copy_timing(t, *in.db, ins.timing);
      copy_counters(t, *in.db, ins.counter);
    }
  }

  void trial_rows() {
    Statement ins_trial = out_.prepare(
        "INSERT INTO trial (id, participant_id, task, setting_id, repetition, block, position, status, session_id, "
        "started_unix_s, ended_unix_s, abort_reason) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)");
    for (const TrialSource& t : trials_) {
      Input& in = inputs_[t.input];
      Statement s = in.db->prepare(
          "SELECT setting_id, task, repetition, block, position, status, session_id, started_unix_s, ended_unix_s, "
          "abort_reason FROM trial WHERE id = ?1");
      s.bind(1, t.id);
      s.step();
      ins_trial.reset();
      ins_trial.bind(1, t.out_id).bind(2, t.participant_out).bind(3, s.column_text(1));
      ins_trial.bind(4, setting_map_.at({t.input, s.column_int64(0)}));
      ins_trial.bind(5, s.column_int64(2)).bind(6, s.column_int64(3)).bind(7, s.column_int64(4)).bind(8, s.column_text(5));
      if (s.is_null(6)) ins_trial.bind_null(9);
      else ins_trial.bind(9, session_map_.at({t.input, s.column_int64(6)}));
      copy_real(ins_trial, 10, s, 7);
      copy_real(ins_trial, 11, s, 8);
      if (s.is_null(9)) ins_trial.bind_null(12);
      else ins_trial.bind(12, s.column_text(9));
      ins_trial.run();
    }
  }

  // The rows that hang off a trial, inserted into the output.
  struct TrialInserts {
    Statement chunk, event, timing, counter;
    explicit TrialInserts(Database& out)
        : chunk(out.prepare("INSERT INTO sample_chunk (trial_id, instrument, first_tick, count, t0_s, data) VALUES "
                            "(?1, ?2, ?3, ?4, ?5, ?6)")),
          event(out.prepare("INSERT INTO event (trial_id, t_s, type, instrument, item_index, detail) VALUES (?1, ?2, "
                            "?3, ?4, ?5, ?6)")),
          timing(out.prepare("INSERT INTO loop_timing (trial_id, count, p50_period_s, p99_period_s, max_period_s, "
                             "mean_period_s, overruns, rejected_periods, dropped_samples, dropped_events) VALUES (?1, "
                             "?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)")),
          counter(out.prepare("INSERT INTO device_counter (trial_id, name, value) VALUES (?1, ?2, ?3)")) {}
  };

  // The trial's chunk rows laid out, then every chunk verified in full
  // under its own place before it is copied (re-checksummed if the trial
  // got a new id).
  static void copy_chunks(const TrialSource& t, Input& in, Statement& ins_chunk, MergeResult& result) {
    Database& db = *in.db;
    std::vector<BadChunk> bad;
    const ChunkLayout layout = layout_chunks(read_chunk_rows(db, t.id), bad);
    if (bad.empty()) check_chunk_coverage(db, t.id, layout, bad);
    if (!bad.empty())
      throw MergeError(in.path.string() + ": damaged sample chunk: " + describe(bad.front()) +
                       "; the site file is refused (nothing merged); `hapticlab study check --db " +
                       in.path.string() + "` lists every finding");
    Statement blob = db.prepare("SELECT t0_s, data FROM sample_chunk WHERE id = ?1");
    ChunkDecoder decoder;
    for (const auto& rows : layout.instrument)
      for (const ChunkRow& row : rows) {
        blob.reset();
        blob.bind(1, row.id);
        blob.step();
        const ChunkPlace from = row.place();
        ChunkPlace to = from;
        to.trial_id = t.out_id;
        std::vector<std::byte> data;
        try {
          if (to.trial_id == from.trial_id) {
            decoder.check(from, blob.column_blob(1));
            const auto b = blob.column_blob(1);
            data.assign(b.begin(), b.end());
          } else {
            data = move_chunk(from, to, blob.column_blob(1));
          }
        } catch (const ChunkError& e) {
          throw MergeError(in.path.string() + ": damaged sample chunk: " +
                           chunk_name(row.trial_id, row.instrument, row.first_tick, row.count) + ": " + e.what() +
                           "; the site file is refused (nothing merged); `hapticlab study check --db " +
                           in.path.string() + "` lists every finding");
        }
        ins_chunk.reset();
        ins_chunk.bind(1, to.trial_id).bind(2, row.instrument).bind(3, row.first_tick).bind(4, row.count);
        ins_chunk.bind(5, blob.column_double(0)).bind_blob(6, data).run();
        ++result.chunks;
      }
  }

  static void copy_events(const TrialSource& t, Database& db, Statement& ins_event) {
    Statement ev = db.prepare("SELECT t_s, type, instrument, item_index, detail FROM event WHERE trial_id = ?1 ORDER BY id");
    ev.bind(1, t.id);
    while (ev.step()) {
      ins_event.reset();
      ins_event.bind(1, t.out_id).bind(2, ev.column_double(0)).bind(3, ev.column_text(1));
      ins_event.bind(4, ev.column_int64(2)).bind(5, ev.column_int64(3));
      if (ev.is_null(4)) ins_event.bind_null(6);
      else ins_event.bind(6, ev.column_text(4));
      ins_event.run();
    }
  }

  static void copy_timing(const TrialSource& t, Database& db, Statement& ins_timing) {
    Statement lt = db.prepare(
        "SELECT count, p50_period_s, p99_period_s, max_period_s, mean_period_s, overruns, rejected_periods, "
        "dropped_samples, dropped_events FROM loop_timing WHERE trial_id = ?1");
    lt.bind(1, t.id);
    while (lt.step()) {
      ins_timing.reset();
      ins_timing.bind(1, t.out_id);
      for (int c = 0; c < 9; ++c) {
        if (lt.is_null(c)) ins_timing.bind_null(c + 2);
        else if (c >= 1 && c <= 4) ins_timing.bind(c + 2, lt.column_double(c));
        else ins_timing.bind(c + 2, lt.column_int64(c));
      }
      ins_timing.run();
    }
  }

  static void copy_counters(const TrialSource& t, Database& db, Statement& ins_counter) {
    Statement dc = db.prepare("SELECT name, value FROM device_counter WHERE trial_id = ?1 ORDER BY name");
    dc.bind(1, t.id);
    while (dc.step()) {
      ins_counter.reset();
      ins_counter.bind(1, t.out_id).bind(2, dc.column_text(0)).bind(3, dc.column_int64(1)).run();
    }
  }

  // The operator's actions of the merged sessions, and those taken while no
  // session ran (a STOP) from every input, each once, in the order taken.
  void operator_actions() {
    struct Action {
      double unix_s;
      std::size_t input;
      std::int64_t id;
      std::optional<std::int64_t> session, trial;
      std::optional<double> t_s;
      std::string type, detail;
    };
    std::vector<Action> all;
    std::set<std::tuple<double, std::string, std::string>> sessionless;
    for (Input& in : inputs_) {
      Statement s = in.db->prepare(
          "SELECT id, session_id, trial_id, unix_s, t_s, type, detail FROM operator_action ORDER BY id");
      while (s.step()) {
        Action a{s.column_double(3), in.index, s.column_int64(0), std::nullopt, std::nullopt, std::nullopt,
                 s.column_text(5), s.column_text(6)};
        if (!s.is_null(4)) a.t_s = s.column_double(4);
        if (!s.is_null(1)) {
          const auto it = session_map_.find({in.index, s.column_int64(1)});
          if (it == session_map_.end()) continue;  // a session of a participant taken from another file
          a.session = it->second;
        } else if (!sessionless.insert({a.unix_s, a.type, a.detail}).second) {
          continue;  // the same STOP from a copy of the same file
        }
        if (!s.is_null(2))
          if (const auto it = trial_map_.find({in.index, s.column_int64(2)}); it != trial_map_.end()) a.trial = it->second;
        all.push_back(std::move(a));
      }
    }
    std::stable_sort(all.begin(), all.end(), [](const Action& a, const Action& b) {
      return std::tie(a.unix_s, a.input, a.id) < std::tie(b.unix_s, b.input, b.id);
    });
    Statement ins = out_.prepare(
        "INSERT INTO operator_action (session_id, trial_id, unix_s, t_s, type, detail) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    for (const Action& a : all) {
      ins.reset();
      if (a.session) ins.bind(1, *a.session);
      else ins.bind_null(1);
      if (a.trial) ins.bind(2, *a.trial);
      else ins.bind_null(2);
      ins.bind(3, a.unix_s);
      if (a.t_s) ins.bind(4, *a.t_s);
      else ins.bind_null(4);
      ins.bind(5, a.type).bind(6, a.detail).run();
    }
  }

  std::vector<Input>& inputs_;
  Database& out_;
  std::vector<Chosen> chosen_;
  std::vector<SessionSource> sessions_;
  std::vector<TrialSource> trials_;
  std::map<std::pair<std::size_t, std::int64_t>, std::int64_t> setting_map_, participant_map_, session_map_, trial_map_;
};

}  // namespace

void copy_study(std::vector<Input>& inputs, const Input& first, const std::map<std::string, std::size_t>& source,
                Database& out, MergeResult& result) {
  Builder build(inputs, out);
  std::size_t k = 0;
  for (SiteSummary& s : result.sites)
    if (!s.skipped) build.summaries[k++] = &s;
  build.study(first);
  build.settings();
  build.participants(source);
  build.rows(result);
  for (const auto& [code, input] : source) {
    ++result.participants;
    for (const Participant& p : inputs[input].participants)
      if (p.code == code && p.sessions > 0) ++build.summaries.at(input)->participants;
  }
}

}  // namespace hapticlab::db::merge
