// Every kind of damage of issue 34 (sections 1 and 2), made on a copy of
// the synthetic study through SQLite's own API -- checksums recomputed
// where the attack needs them -- and every reader run on every copy: the
// real `hapticlab` binary (`study check` in text and --json, `export`,
// `analyze`, `sim replay --db`), the SQL extension in the real sqlite3
// shell, and the Python reader in /usr/bin/python3. Each reader must refuse
// the damage and name it (the file, the trial, the instrument where it
// applies, the reason); none may pass it silently, hang, or crash. The
// clean copy, read by the same readers, passes everywhere.
#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <zstd.h>

#include "analysis/study/synthetic_study_db.h"
#include "app/cli_process.h"
#include "db/db_test_util.h"
#include "db/sample_codec.h"
#include "db/sqlite_handle.h"

namespace hapticlab::app {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// One shell word (POSIX sh single quotes).
std::string sh_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// No reader may hang on a damaged file (a recursive view used to make
// export and analyze run past 65 s): every process gets this long.
const std::string kTimeout = "timeout 60 ";

std::pair<int, std::string> run_hapticlab(const std::string& args) {
  return testing::run_cli(kTimeout + HAPTICLAB_CLI_PATH, args);
}

// The synthetic study's chunk of (trial, instrument): ticks 0..9.
std::int64_t chunk_of(db::Database& db, std::int64_t trial, int instrument) {
  db::Statement s = db.prepare("SELECT id FROM sample_chunk WHERE trial_id = ?1 AND instrument = ?2");
  s.bind(1, trial).bind(2, std::int64_t{instrument});
  if (!s.step()) throw db::DbError("no chunk of trial " + std::to_string(trial));
  return s.column_int64(0);
}

std::vector<std::byte> blob_of(db::Database& db, std::int64_t id) {
  db::Statement s = db.prepare("SELECT data FROM sample_chunk WHERE id = ?1");
  s.bind(1, id);
  s.step();
  const std::span<const std::byte> b = s.column_blob(0);
  return {b.begin(), b.end()};
}

void store_blob(db::Database& db, std::int64_t id, const std::vector<std::byte>& blob) {
  db.prepare("UPDATE sample_chunk SET data = ?2 WHERE id = ?1").bind(1, id).bind_blob(2, blob).run();
}

// Ten valid samples of ticks first .. first + 9 (wrapping past 2^64 for a
// negative first tick), as a chunk of (trial, instrument) whose checksum is
// right for that row: only the chunks' layout can refuse it.
void insert_valid_chunk(db::Database& db, std::int64_t trial, std::int64_t instrument, std::int64_t first) {
  std::vector<db::StoredSample> samples(10);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    samples[i].tick = static_cast<std::uint64_t>(first) + i;
    samples[i].t_s = static_cast<double>(i) / 8.0;
    samples[i].dt_s = 1.0 / 8.0;
  }
  const std::vector<std::byte> blob = db::encode_chunk(trial, static_cast<int>(instrument), samples);
  db.exec("PRAGMA ignore_check_constraints = ON");  // instrument IN (0, 1): the damage goes round it
  db.prepare("INSERT INTO sample_chunk (trial_id, instrument, first_tick, count, t0_s, data) "
             "VALUES (?1, ?2, ?3, 10, 0, ?4)")
      .bind(1, trial).bind(2, instrument).bind(3, first).bind_blob(4, blob).run();
}

// A zstd frame of `content`, with its content checksum.
std::vector<std::byte> checksummed_frame(const std::vector<std::byte>& content) {
  ZSTD_CCtx* c = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(c, ZSTD_c_checksumFlag, 1);
  std::vector<std::byte> out(ZSTD_compressBound(content.size()));
  out.resize(ZSTD_compress2(c, out.data(), out.size(), content.data(), content.size()));
  ZSTD_freeCCtx(c);
  return out;
}

// Chunk `id`'s frame replaced by `frame`, its CRC recomputed for its row.
void store_frame(db::Database& db, std::int64_t id, const std::vector<std::byte>& frame) {
  std::vector<std::byte> blob = blob_of(db, id);
  blob.resize(db::kChunkHeaderBytes);
  blob.insert(blob.end(), frame.begin(), frame.end());
  store_blob(db, id, db::testing::resign_blob(std::move(blob), db::testing::chunk_place(db, id)));
}

struct Damage {
  const char* name;
  std::function<void(db::Database&, std::int64_t trial)> make;
  std::int64_t trial;  // the trial damaged: replayed, queried, named
  std::vector<std::string> named;  // every reader's message holds each of these
  const char* check;  // the kind of `study check --json` finding that names it
  bool whole_file;    // refused at the door (else the chunk is left out)
};

// The synthetic study (tests/analysis/study/synthetic_study_db.h): P1 ran
// trials 1..6 and aborted 7, P2 ran 8..11 (12 is planned); every trial's
// two chunks hold ticks 0..9. A chunk's damage is made in a trial of its
// own, so all of them share one copy; damage that refuses the whole file
// gets a copy each.
std::vector<Damage> damage_cases() {
  const auto moved = [](db::Database& db, std::int64_t trial) {
    // The previous trial's left chunk put in place of this one's.
    db.prepare("DELETE FROM sample_chunk WHERE trial_id = ?1 AND instrument = 0").bind(1, trial).run();
    db.prepare("UPDATE sample_chunk SET trial_id = ?1 WHERE trial_id = ?1 - 1 AND instrument = 0").bind(1, trial).run();
  };
  const auto swapped = [](db::Database& db, std::int64_t trial) {
    const std::int64_t left = chunk_of(db, trial, 0), right = chunk_of(db, trial, 1);
    const std::vector<std::byte> a = blob_of(db, left), b = blob_of(db, right);
    store_blob(db, left, b);
    store_blob(db, right, a);
  };
  const auto frame_byte = [](db::Database& db, std::int64_t trial) {
    // A byte inside the frame changed and the CRC recomputed; the first
    // such byte (from the middle on) that changes the frame's content.
    const std::int64_t id = chunk_of(db, trial, 0);
    const std::vector<std::byte> blob = blob_of(db, id);
    const db::ChunkPlace place = db::testing::chunk_place(db, id);
    for (std::size_t i = blob.size() / 2; i < blob.size(); ++i) {
      std::vector<std::byte> bad = blob;
      bad[i] ^= std::byte{0x10};
      bad = db::testing::resign_blob(std::move(bad), place);
      std::vector<db::StoredSample> out;
      try {
        db::decode_chunk(place, bad, out);
      } catch (const db::ChunkError&) {
        store_blob(db, id, bad);
        return;
      }
    }
    throw db::DbError("no frame byte changes the content");
  };
  const auto frame_content = [](db::Database& db, std::int64_t trial) {
    const std::vector<std::byte> blob = blob_of(db, chunk_of(db, trial, 0));
    const auto frame = std::span(blob).subspan(db::kChunkHeaderBytes);
    std::vector<std::byte> content(ZSTD_getFrameContentSize(frame.data(), frame.size()));
    ZSTD_decompress(content.data(), content.size(), frame.data(), frame.size());
    return content;
  };
  const auto second_frame = [=](db::Database& db, std::int64_t trial) {
    std::vector<std::byte> two = checksummed_frame(frame_content(db, trial));
    const std::vector<std::byte> more = checksummed_frame(frame_content(db, trial));
    two.insert(two.end(), more.begin(), more.end());
    store_frame(db, chunk_of(db, trial, 0), two);
  };
  const auto bomb = [](db::Database& db, std::int64_t trial) {
    // 64 MiB of zeros stated in a frame of a few kB, for a chunk of 10
    // updates (at most 28 + 10 * 117 = 1198 bytes).
    store_frame(db, chunk_of(db, trial, 0), checksummed_frame(std::vector<std::byte>(64 << 20)));
  };
  const auto sql = [](std::string text) {
    return [text](db::Database& db, std::int64_t) { db.exec(text); };
  };
  return {
      {"clean", nullptr, 1, {}, "", false},
      {"moved_to_another_trial", moved, 2, {"trial 2, left instrument (0), ticks 0..9: checksum mismatch"}, "chunk",
       false},
      {"instruments_swapped", swapped, 3, {"trial 3, left instrument (0), ticks 0..9: checksum mismatch"}, "chunk",
       false},
      {"overlapping_ticks", [](db::Database& db, std::int64_t t) { insert_valid_chunk(db, t, 0, 5); }, 4,
       {"trial 4, left instrument (0), ticks 0..9: its ticks overlap those of the chunk with ticks 5..14"}, "chunk",
       false},
      {"instrument_2", [](db::Database& db, std::int64_t t) { insert_valid_chunk(db, t, 2, 0); }, 5,
       {"trial 5, unknown instrument (2), ticks 0..9: instrument 2 is neither 0 (left) nor 1 (right)"}, "chunk",
       false},
      {"negative_first_tick", [](db::Database& db, std::int64_t t) { insert_valid_chunk(db, t, 0, -10); }, 6,
       {"trial 6, left instrument (0), ticks -10..-1: first tick -10 is negative"}, "chunk", false},
      {"frame_byte_changed", frame_byte, 8,
       {"trial 8, left instrument (0), ticks 0..9: the zstd frame does not decompress"}, "chunk", false},
      {"second_frame", second_frame, 9,
       {"trial 9, left instrument (0), ticks 0..9: ", "bytes follow the zstd frame (a chunk holds exactly one frame)"},
       "chunk", false},
      {"zstd_bomb", bomb, 10,
       {"trial 10, left instrument (0), ticks 0..9: the zstd frame's header states 67108864 bytes, more than the 1198"},
       "chunk", false},
      {"participant_row_missing", sql("PRAGMA foreign_keys = OFF; DELETE FROM participant WHERE code = 'P2'"), 8,
       {"trial 8: participant_id 2 refers to no participant row"}, "foreign_key", true},
      // Trial 2 is P1's Cogging trial of repetition 1.
      {"setting_row_missing", sql("PRAGMA foreign_keys = OFF; DELETE FROM setting WHERE name = 'Cogging'"), 2,
       {"setting_id 3 refers to no setting row"}, "foreign_key", true},
      {"event_time_text_nan", sql("UPDATE event SET t_s = 'nan' WHERE trial_id = 1 AND type = 'contact_end'"), 1,
       {"of trial 1: t_s is text 'nan', expected a REAL"}, "type", true},
      {"chunk_data_text", sql("UPDATE sample_chunk SET data = 'not a blob' WHERE trial_id = 1 AND instrument = 0"), 1,
       {"data is text"}, "type", true},
      // Edited with an SQLite shell: what a session configures its engine
      // with, and what defines the schedule (the digests of schema 11).
      {"setting_edited",
       sql(R"(UPDATE setting SET parameters_json = '{"translation": {"friction": {}}}' WHERE name = 'Cogging')"), 2,
       {"setting 'Cogging' (id 3): its parameters_json does not match the SHA-256 stored with it"},
       "edited", true},
      {"protocol_edited", sql(R"(UPDATE study SET protocol_json = '{"study": "edited"}')"), 1,
       {"study 1: its protocol_json does not match the SHA-256 stored with it"}, "edited", true},
      {"event_a_recursive_view",
       sql("PRAGMA foreign_keys = OFF; DROP TABLE event; "
           "CREATE VIEW event (id, trial_id, t_s, type, instrument, item_index, detail) AS "
           "WITH RECURSIVE n(k) AS (SELECT 1 UNION ALL SELECT k + 1 FROM n) "
           "SELECT k, 1, 0.5, 'contact_start', 0, 0, NULL FROM n"),
       1, {"table event is a view, not a table"}, "schema", true},
  };
}

// `text` holds every one of `named`, and the file's name when it refuses.
void expect_named_by(const std::string& text, const std::vector<std::string>& named, const std::string& reader,
                     const fs::path& file) {
  for (const std::string& n : named) EXPECT_THAT(text, HasSubstr(n)) << reader << ":\n" << text.substr(0, 3000);
  if (!named.empty()) {
    EXPECT_THAT(text, HasSubstr(file.string())) << reader << " does not name the file";
  }
}

// A copy of the study and the damage done to it.
struct DamagedCopy {
  fs::path path;
  std::vector<const Damage*> damage;  // none: the clean copy
  bool whole_file = false;
};

class StudyFileDamageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    clean_ = dir_.path() / "synthetic.db";
    analysis::testing::build_synthetic_study(clean_);
  }

  analysis::testing::ScratchDir dir_;
  fs::path clean_;
};

TEST_F(StudyFileDamageTest, EveryReaderRefusesEveryDamageAndNamesIt) {
  const std::vector<Damage> cases = damage_cases();
  std::vector<DamagedCopy> copies;
  for (const Damage& d : cases) {
    const bool shared = d.make && !d.whole_file;
    if (!shared || copies.empty() || copies.back().damage.empty() || copies.back().whole_file) {
      copies.push_back({dir_.path() / (std::string(shared ? "chunk_damage" : d.name) + ".db"), {}, d.whole_file});
      fs::copy_file(clean_, copies.back().path);
    }
    if (!d.make) continue;
    copies.back().damage.push_back(&d);
    db::Database conn(copies.back().path);
    d.make(conn, d.trial);
  }
  std::vector<fs::path> path_of(cases.size(), copies.front().path);
  for (const DamagedCopy& c : copies)
    for (const Damage* d : c.damage) path_of[static_cast<std::size_t>(d - cases.data())] = c.path;

  // The Python reader, once for every case: open the copy, read the trial.
  const std::string script =
      "import json, sys\nsys.path.insert(0, sys.argv[1])\nimport hapticlab_db as h\n"
      "for path, trial in zip(sys.argv[2::2], sys.argv[3::2]):\n"
      "    try:\n"
      "        with h.open_study(path) as db:\n"
      "            n = db.samples(int(trial)).size\n"
      "        print(json.dumps({'ok': True, 'rows': int(n)}))\n"
      "    except (h.ChunkError, h.StructureError) as e:\n"
      "        print(json.dumps({'ok': False, 'type': type(e).__name__, 'message': str(e)}))\n"
      "    except Exception as e:\n"
      "        print(json.dumps({'ok': False, 'type': 'UNNAMED ' + type(e).__name__, 'message': str(e)}))\n";
  std::string python = kTimeout + HAPTICLAB_PYTHON + " -c " + sh_quote(script) + " " +
                       sh_quote(std::string(HAPTICLAB_SOURCE_DIR) + "/python");
  for (std::size_t k = 0; k < cases.size(); ++k)
    python += " " + sh_quote(path_of[k].string()) + " " + std::to_string(cases[k].trial);
  const auto [python_status, python_out] = testing::run_shell(python + " 2>&1");
  ASSERT_EQ(python_status, 0) << python_out;
  std::vector<nlohmann::json> python_results;
  {
    std::istringstream lines(python_out);
    for (std::string line; std::getline(lines, line);) python_results.push_back(nlohmann::json::parse(line));
  }
  ASSERT_EQ(python_results.size(), cases.size()) << python_out;

  // The readers of a whole file, once per copy: every damage in it named.
  for (const DamagedCopy& c : copies) {
    SCOPED_TRACE(c.path.filename().string());
    const std::string db = sh_quote(c.path.string());
    const bool clean = c.damage.empty();
    std::vector<std::string> named;
    for (const Damage* d : c.damage) named.insert(named.end(), d->named.begin(), d->named.end());
    const std::string out_dir = (dir_.path() / (c.path.stem().string() + "_out")).string();

    // study check, text and JSON (every finding listed, naming the trial).
    const auto [check_status, check] = run_hapticlab("study check --db " + db);
    EXPECT_EQ(check_status, clean ? 0 : 1) << check;
    expect_named_by(check, named, "study check", c.path);
    const auto [json_status, json_text] =
        testing::run_cli_stdout(kTimeout + HAPTICLAB_CLI_PATH, "study check --json --db " + db);
    EXPECT_EQ(json_status, clean ? 0 : 1);
    const nlohmann::json json = nlohmann::json::parse(json_text, nullptr, false);
    ASSERT_FALSE(json.is_discarded()) << json_text;
    EXPECT_EQ(json["ok"], clean);
    if (clean) {
      EXPECT_TRUE(json["findings"].empty()) << json_text;
    }
    for (const Damage* d : c.damage) {
      bool found = false;
      for (const nlohmann::json& f : json["findings"]) {
        const std::string message = f["message"];
        bool all = f["check"] == d->check;
        for (const std::string& n : d->named) all = all && message.find(n) != std::string::npos;
        // A table's shape and an edited definition belong to no trial.
        if (all && std::string(d->check) != "schema" && std::string(d->check) != "edited")
          all = f.contains("trial_id") && f["trial_id"] == d->trial;
        found = found || all;
      }
      EXPECT_TRUE(found) << "no '" << d->check << "' finding of trial " << d->trial << " naming " << d->name << ":\n"
                         << json_text;
    }

    // export: a damaged chunk is left out and named (exit 1), a damaged
    // file refused at the door.
    const auto [export_status, exported] =
        run_hapticlab("export --db " + db + " --format csv --out " + sh_quote(out_dir + "/csv"));
    EXPECT_EQ(export_status, clean ? 0 : 1) << exported;
    expect_named_by(exported, named, "export", c.path);

    // analyze: a damaged chunk is left out, named, its trial's measures
    // missing, the rest written and exit 1 (as export); a damaged file is
    // refused.
    const auto [analyze_status, analysed] =
        run_hapticlab("analyze --db " + db + " --out " + sh_quote(out_dir + "/analysis") + " --no-plots --no-ks");
    EXPECT_EQ(analyze_status, clean ? 0 : 1) << analysed;
    if (!clean && !c.whole_file) {
      EXPECT_THAT(analysed, HasSubstr("damaged sample chunk(s) left out, listed above: the results in ")) << analysed;
      EXPECT_TRUE(fs::exists(out_dir + "/analysis/metrics.csv")) << "the readable trials' results were not written";
    }
    expect_named_by(analysed, named, "analyze", c.path);
    if (!c.whole_file) {
      for (const Damage* d : c.damage) {
        EXPECT_THAT(analysed, HasSubstr("trial " + std::to_string(d->trial) + "'s measures are missing")) << analysed;
      }
    }
  }

  // The readers of one trial, per case.
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const Damage& d = cases[k];
    SCOPED_TRACE(d.name);
    const std::string db = sh_quote(path_of[k].string());
    const std::string trial = std::to_string(d.trial);
    const bool clean = d.named.empty();

    // sim replay of the trial: refused.
    const auto [replay_status, replayed] = run_hapticlab(
        "sim replay --db " + db + " --trial " + trial + " --out " + sh_quote((dir_.path() / "replay.csv").string()));
    EXPECT_EQ(replay_status, clean ? 0 : 1) << replayed;
    expect_named_by(replayed, d.named, "sim replay", path_of[k]);

    // The SQL extension in the sqlite3 shell: an error, and no row of the trial.
    const auto [sql_status, sql] = testing::run_cli(
        kTimeout + HAPTICLAB_SQLITE3_CLI,
        "-bail " + db + " " + sh_quote(std::string(".load ") + HAPTICLAB_SQLITE_EXTENSION) + " " +
            sh_quote("SELECT count(*) FROM samples(" + trial + ")"));
    EXPECT_EQ(sql_status == 0, clean) << sql;
    expect_named_by(sql, d.named, "SQL extension", path_of[k]);
    if (!clean) {
      EXPECT_THAT(sql, ::testing::Not(::testing::ContainsRegex("^[0-9]"))) << sql;
    }

    // The Python reader: a named ChunkError or StructureError, nothing else.
    const nlohmann::json& py = python_results[k];
    EXPECT_EQ(py["ok"], clean) << py.dump();
    if (clean) {
      EXPECT_EQ(py["rows"], 20) << py.dump();
    } else {
      EXPECT_THAT(py.value("type", std::string("(none: accepted)")), ::testing::AnyOf("ChunkError", "StructureError"))
          << py.dump();
      expect_named_by(py.value("message", std::string()), d.named, "Python", path_of[k]);
    }
  }
}

// Issue 34 section 2: within the format's own limits, eight valid all-zero
// chunks (35 kB on disk) drove export to 2.4 GB and the Python reader to
// 3.3 GB, each holding a trial's samples at once. Here four chunks of 2^17
// updates per instrument (every channel stored per update, all zero: a
// valid body that zstd shrinks to a few kB), 1 Mi samples in all: `export`
// must stay within a chunk per instrument (2 x 15 MB decompressed; measured
// 42 MB in all, 0.27 GB when it reads every sample first) however many
// chunks there are, and the Python reader within its result (134 bytes a
// row) plus about that (measured 60 MB beyond it, 171 MB when it keeps
// every chunk's arrays). The bound on export leaves room for ASan.
TEST_F(StudyFileDamageTest, ZeroChunksWithinTheFormatsLimitKeepEveryReaderSmall) {
  constexpr std::uint64_t kCount = std::uint64_t{1} << 17;
  constexpr int kChunksPerInstrument = 4;
  const fs::path path = dir_.path() / "zero_chunks.db";
  fs::copy_file(clean_, path);
  {
    db::Database conn(path);
    conn.exec("DELETE FROM sample_chunk WHERE trial_id = 1");
    // 28 tags of 0 (per update) and every value 0: the preconditioned
    // body of all-zero samples is all zero too.
    const std::vector<std::byte> frame = checksummed_frame(std::vector<std::byte>(28 + 117 * kCount));
    for (std::int64_t instrument = 0; instrument < 2; ++instrument)
      for (int k = 0; k < kChunksPerInstrument; ++k) {
        std::vector<std::byte> blob(db::kChunkHeaderBytes);
        blob[0] = std::byte{3};
        blob.insert(blob.end(), frame.begin(), frame.end());
        const db::ChunkPlace place{1, instrument, k * kCount, kCount};
        conn.prepare("INSERT INTO sample_chunk (trial_id, instrument, first_tick, count, t0_s, data) "
                     "VALUES (1, ?1, ?2, ?3, 0, ?4)")
            .bind(1, instrument).bind(2, static_cast<std::int64_t>(place.first_tick))
            .bind(3, static_cast<std::int64_t>(kCount))
            .bind_blob(4, db::testing::resign_blob(blob, place)).run();
      }
  }
  // Peak memory of a child, as the kernel counts it (ru_maxrss, kB). A
  // small ASan quarantine, so that freed buffers are not counted as held.
  const std::string measure =
      "ASAN_OPTIONS=\"${ASAN_OPTIONS:+$ASAN_OPTIONS:}quarantine_size_mb=8\" " + kTimeout + HAPTICLAB_PYTHON +
      " -c " +
      sh_quote("import resource, subprocess, sys\n"
               "r = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)\n"
               "print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n");
  const auto peak_kB = [](const std::string& out) {
    std::istringstream in(out);
    int status = -1;
    long kB = -1;
    in >> status >> kB;
    EXPECT_EQ(status, 0) << out;
    return kB;
  };
  const std::string db = sh_quote(path.string());
  const auto [export_status, exported] =
      testing::run_shell(measure + " " + HAPTICLAB_CLI_PATH + " export --db " + db +
                         " --trial 1 --format csv --channels t_s --every 1000000 --out " +
                         sh_quote((dir_.path() / "zero_out").string()) + " 2>&1");
  ASSERT_EQ(export_status, 0) << exported;
  EXPECT_LT(peak_kB(exported), 150'000) << "export of 2 x 4 chunks of 2^17 updates: " << exported;
  EXPECT_TRUE(fs::exists(dir_.path() / "zero_out"));

  // The Python reader: its result (134 bytes a row) and one chunk's arrays.
  const std::string script =
      "import resource, sys\nsys.path.insert(0, sys.argv[1])\nimport hapticlab_db as h\n"
      "with h.open_study(sys.argv[2]) as db:\n"
      "    s = db.samples(1)\n"
      "print(s.size, s.nbytes // 1024, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\n";
  const auto [python_status, python_out] = testing::run_shell(
      kTimeout + HAPTICLAB_PYTHON + " -c " + sh_quote(script) + " " +
      sh_quote(std::string(HAPTICLAB_SOURCE_DIR) + "/python") + " " + db + " 2>&1");
  ASSERT_EQ(python_status, 0) << python_out;
  std::istringstream in(python_out);
  long rows = 0, result_kB = 0, python_kB = 0;
  in >> rows >> result_kB >> python_kB;
  EXPECT_EQ(rows, 2 * kChunksPerInstrument * static_cast<long>(kCount)) << python_out;
  EXPECT_LT(python_kB - result_kB, 110'000) << "the Python reader beyond its result: " << python_out;
}

}  // namespace
}  // namespace hapticlab::app
