#include "db/export_csv.h"

#include <charconv>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db_test_util.h"

namespace hapticlab::db {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using Row = std::vector<std::string>;

// RFC 4180 reader: quoted fields may hold commas, quotes ("") and newlines.
std::vector<Row> read_csv(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  std::vector<Row> rows;
  Row row;
  std::string field;
  bool quoted = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (quoted) {
      if (c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      row.push_back(std::move(field));
      field.clear();
    } else if (c == '\n') {
      row.push_back(std::move(field));
      field.clear();
      rows.push_back(std::move(row));
      row.clear();
    } else {
      field += c;
    }
  }
  EXPECT_TRUE(row.empty() && field.empty()) << path << " does not end with a line break";
  return rows;
}

template <typename T = double>
T number(const std::string& text) {
  T v{};
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
  EXPECT_TRUE(r.ec == std::errc() && r.ptr == text.data() + text.size()) << "not a number: '" << text << "'";
  return v;
}

std::size_t column(const Row& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i)
    if (header[i] == name) return i;
  ADD_FAILURE() << "no column " << name;
  return 0;
}

std::vector<StoredSample> samples_of(std::uint64_t first, std::uint64_t count, int instrument) {
  std::vector<StoredSample> out;
  for (std::uint64_t t = first; t < first + count; ++t) {
    const LoopSample s = testing::make_sample(t);
    out.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[static_cast<std::size_t>(instrument)]});
  }
  return out;
}

// One study: P01 with a complete trial (samples in two chunks per
// instrument, events, loop timing), an aborted one and a planned one.
struct Study {
  testing::TempDir dir;
  StudyDb db{dir.file("study.db")};
  std::int64_t study = 0, complete = 0, aborted = 0, planned = 0;
  Study() {
    study = db.add_study({"Export, \"quoted\" study", "{}", 3, "test"});
    const std::int64_t p = db.add_participant(study, "P01");
    const std::int64_t s = db.add_setting_json(study, "All Degradations", "{}");
    const std::int64_t session = db.begin_session(p, "sim", "virtual", 1000.0);
    complete = db.add_trial({p, "dissection", s, 1, 1, 1});
    aborted = db.add_trial({p, "clip", s, 2, 1, 2});
    planned = db.add_trial({p, "clip", s, 3, 2, 3});
    db.start_trial(complete, session);
    for (int k = 0; k < 2; ++k) {
      db.insert_chunk(complete, k, samples_of(0, 40, k));
      db.insert_chunk(complete, k, samples_of(40, 25, k));
    }
    db.add_event({complete, 0.012, "contact_start", 1, 0, ""});
    db.add_event({complete, 0.030, "operator_note", -1, 0, "said \"ouch\", paused\nthen went on"});
    LoopTimingSummary timing;
    timing.count = 64;
    timing.p50_period_s = 1e-3;
    timing.p99_period_s = 1.25e-3;
    db.set_loop_timing(complete, timing, 2, 0);
    db.end_trial(complete, TrialStatus::kComplete);
    db.start_trial(aborted, session);
    db.insert_chunk(aborted, 0, samples_of(0, 5, 0));
    db.insert_chunk(aborted, 1, samples_of(0, 5, 1));
    db.end_trial(aborted, TrialStatus::kAborted, "device fault, motor 2");
  }
};

TEST(ExportCsv, OneTrialWritesEverySampleAndEventReadingBackToTheStoredValues) {
  Study s;
  const fs::path out = s.dir.file("out");
  const std::vector<fs::path> files = export_trial_csv(s.db, s.complete, out);
  const std::string stem = "p01_dissection_all_degradations_rep1_trial" + std::to_string(s.complete);
  ASSERT_EQ(files.size(), 2u);
  EXPECT_EQ(files[0], out / (stem + "_samples.csv"));
  EXPECT_EQ(files[1], out / (stem + "_events.csv"));

  const std::vector<Row> rows = read_csv(files[0]);
  ASSERT_EQ(rows.size(), 1u + 2u * 65u);
  const Row& h = rows[0];
  ASSERT_EQ(h.size(), 7u + kChunkChannels);
  EXPECT_EQ((Row(h.begin(), h.begin() + 7)),
            (Row{"trial_id", "participant", "task", "setting", "repetition", "instrument", "tick"}));
  for (std::size_t c = 0; c < kChunkChannels; ++c) EXPECT_EQ(h[7 + c], kChannelNames[c]);

  for (int k = 0; k < 2; ++k) {
    const std::vector<StoredSample> stored = s.db.samples(s.complete, k);
    for (std::uint64_t t = 0; t < 65; ++t) {
      // Tick order, left before right within a tick.
      const Row& r = rows[1 + 2 * t + static_cast<std::uint64_t>(k)];
      ASSERT_EQ(r.size(), h.size());
      EXPECT_EQ(r[column(h, "trial_id")], std::to_string(s.complete));
      EXPECT_EQ(r[column(h, "participant")], "P01");
      EXPECT_EQ(r[column(h, "setting")], "All Degradations");
      EXPECT_EQ(r[column(h, "instrument")], std::to_string(k));
      EXPECT_EQ(r[column(h, "tick")], std::to_string(t));
      const StoredSample& v = stored[t];
      // Shortest round-trip text: float64 channels read back as doubles
      // exactly, float32 channels as floats to exactly what is stored.
      EXPECT_EQ(number(r[column(h, "t_s")]), v.t_s);
      EXPECT_EQ(number(r[column(h, "dt_s")]), v.dt_s);
      const auto f32 = [&](const char* name) { return double{number<float>(r[column(h, name)])}; };
      EXPECT_EQ(f32("raw_insertion_m"), v.value.raw_position[0]);
      EXPECT_EQ(f32("raw_grip_rad"), v.value.raw_position[4]);
      EXPECT_EQ(f32("degraded_yaw_rad"), v.value.degraded_position[2]);
      EXPECT_EQ(f32("tip_vz_m_per_s"), v.value.tip_velocity_m_per_s[2]);
      EXPECT_EQ(f32("ve_force_y_N"), v.value.ve_force_N[1]);
      EXPECT_EQ(f32("displayed_force_x_N"), v.value.displayed_force_N[0]);
      EXPECT_EQ(f32("yaw_torque_Nm"), v.value.joint_force[2]);
      EXPECT_EQ(r[column(h, "engine_status")], std::to_string(v.value.engine_status));
      EXPECT_EQ(r[column(h, "device_status")], std::to_string(v.device_status));
      EXPECT_EQ(r[column(h, "in_contact")], v.value.in_contact ? "1" : "0");
      // And what is stored is the float32 of what the loop sent.
      EXPECT_EQ(v.value.ve_force_N[1],
                double{to_stored_float(testing::make_sample(t).instrument[static_cast<std::size_t>(k)].ve_force_N[1])});
    }
  }

  const std::vector<Row> events = read_csv(files[1]);
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0], (Row{"trial_id", "participant", "task", "setting", "repetition", "t_s", "type", "instrument",
                            "item_index", "detail"}));
  const std::string id = std::to_string(s.complete);
  EXPECT_EQ(events[1], (Row{id, "P01", "dissection", "All Degradations", "1", "0.012", "contact_start", "1", "0", ""}));
  EXPECT_EQ(events[2], (Row{id, "P01", "dissection", "All Degradations", "1", "0.03", "operator_note", "-1", "0",
                            "said \"ouch\", paused\nthen went on"}));
  for (const auto& entry : fs::directory_iterator(out))
    EXPECT_NE(entry.path().extension(), ".tmp") << "temporary file left behind";
}

TEST(ExportCsv, WholeStudyWritesTheTrialIndexAndEveryStartedTrial) {
  Study s;
  const fs::path out = s.dir.file("study_out");
  // The console's operator actions: one during a trial, one of no session (a STOP while none ran).
  OperatorActionRow note;
  note.session_id = 1;
  note.trial_id = s.complete;
  note.unix_s = 1.5e9;
  note.t_s = 0.25;
  note.type = "operator_note";
  note.detail = "chair, \"lower\"";
  s.db.add_operator_action(note);
  OperatorActionRow stop;
  stop.unix_s = 1.5e9 + 1;
  stop.type = "operator_stop";
  stop.detail = "nothing was running";
  s.db.add_operator_action(stop);
  const std::vector<fs::path> files = export_study_csv(s.db, s.study, out);
  // 2 started trials x (samples, events) + trials.csv + operator_actions.csv
  ASSERT_EQ(files.size(), 6u);
  EXPECT_EQ(files[4], out / "trials.csv");
  EXPECT_EQ(files.back(), out / "operator_actions.csv");
  const std::vector<Row> actions = read_csv(out / "operator_actions.csv");
  ASSERT_EQ(actions.size(), 3u);
  EXPECT_EQ(actions[0], (Row{"id", "session_id", "participant", "trial_id", "unix_s", "t_s", "type", "detail"}));
  EXPECT_EQ(actions[1], (Row{"1", "1", "P01", std::to_string(s.complete), "1.5e+09", "0.25", "operator_note",
                             "chair, \"lower\""}));
  EXPECT_EQ(actions[2], (Row{"2", "", "", "", "1500000001", "", "operator_stop", "nothing was running"}));
  std::size_t csv_files = 0;
  for (const auto& entry : fs::directory_iterator(out)) {
    ++csv_files;
    EXPECT_THAT(entry.path().filename().string(), ::testing::Not(HasSubstr(
                                                      "trial" + std::to_string(s.planned) + "_")))
        << "a planned trial has no data to export";
  }
  EXPECT_EQ(csv_files, 6u);

  const std::vector<Row> rows = read_csv(out / "trials.csv");
  ASSERT_EQ(rows.size(), 4u);
  const Row& h = rows[0];
  const auto at = [&](std::size_t row, const char* name) { return rows[row][column(h, name)]; };
  EXPECT_EQ(at(1, "trial_id"), std::to_string(s.complete));
  EXPECT_EQ(at(1, "status"), "complete");
  EXPECT_EQ(at(1, "updates"), "65");
  EXPECT_EQ(number(at(1, "loop_p99_period_s")), 1.25e-3);
  EXPECT_EQ(at(1, "dropped_samples"), "2");
  EXPECT_FALSE(at(1, "ended_unix_s").empty());
  EXPECT_EQ(at(2, "status"), "aborted");
  EXPECT_EQ(at(2, "abort_reason"), "device fault, motor 2");
  EXPECT_EQ(at(2, "updates"), "5");
  EXPECT_EQ(at(2, "loop_p99_period_s"), "") << "no timing was recorded";
  EXPECT_EQ(at(3, "status"), "planned");
  EXPECT_EQ(at(3, "position"), "3");
  EXPECT_EQ(at(3, "block"), "2");
  EXPECT_EQ(at(3, "started_unix_s"), "");
  for (const Row& r : rows) EXPECT_EQ(r.size(), h.size());

  const std::vector<Row> aborted_samples =
      read_csv(out / ("p01_clip_all_degradations_rep2_trial" + std::to_string(s.aborted) + "_samples.csv"));
  EXPECT_EQ(aborted_samples.size(), 1u + 2u * 5u) << "an aborted trial's samples are exported too";
}

TEST(ExportCsv, UnknownTrialNamesIt) {
  Study s;
  try {
    export_trial_csv(s.db, 4242, s.dir.file("x"));
    FAIL();
  } catch (const DbError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no trial with id 4242"));
  }
}

}  // namespace
}  // namespace hapticlab::db

namespace hapticlab::db {
namespace {

// A flipped byte in one chunk (left instrument, ticks 40..64): its rows are
// left out and the chunk is reported; never exported as wrong numbers.
TEST(ExportCsv, DamagedChunkIsLeftOutAndReported) {
  Study s;
  testing::flip_chunk_byte(s.db.connection(), 2, 30);  // id 2: the complete trial's left ticks 40..64
  const fs::path out = s.dir.file("out");
  std::vector<BadChunk> bad;
  const std::vector<fs::path> files = export_trial_csv(s.db, s.complete, out, &bad);
  ASSERT_EQ(bad.size(), 1u);
  EXPECT_EQ(bad[0].trial_id, s.complete);
  EXPECT_EQ(bad[0].instrument, 0);
  EXPECT_EQ(bad[0].first_tick, 40u);
  EXPECT_EQ(bad[0].count, 25u);
  EXPECT_THAT(describe(bad[0]), HasSubstr("left instrument (0), ticks 40..64: checksum mismatch"));

  const std::vector<Row> rows = read_csv(files.at(0));
  ASSERT_EQ(rows.size(), 1u + 40u + 65u) << "header, left 0..39, right 0..64";
  const std::size_t instrument = column(rows[0], "instrument"), tick = column(rows[0], "tick");
  for (std::size_t i = 1; i < rows.size(); ++i)
    EXPECT_FALSE(rows[i][instrument] == "0" && number<std::uint64_t>(rows[i][tick]) >= 40) << "row " << i;

  // With nobody to report to, the export refuses and leaves no file.
  const fs::path out2 = s.dir.file("out2");
  EXPECT_THAT([&] { export_trial_csv(s.db, s.complete, out2); },
              ::testing::ThrowsMessage<DbError>(HasSubstr("ticks 40..64: checksum mismatch")));
  EXPECT_TRUE(fs::is_empty(out2));
}

}  // namespace
}  // namespace hapticlab::db
