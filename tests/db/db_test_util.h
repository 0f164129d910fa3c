#pragma once
// Shared by the db tests: a fresh temporary directory per test, removed
// afterwards, and a LoopSample whose every channel depends on its tick.
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <zstd.h>

#include "core/loop/loop_sample.h"
#include "db/sample_codec.h"
#include "db/study_db.h"
#include "tests/testing/scratch_dir.h"

namespace hapticlab::db::testing {

// A chunk blob as schema versions 1..3 wrote it (format 1 before checksums):
// byte 1, then the body that today follows the 5-byte header. For making
// old files; the golden test in sample_codec_test.cc pins it to the old bytes.
inline std::vector<std::byte> legacy_blob(std::span<const StoredSample> samples) {
  const std::vector<std::byte> blob = encode_chunk(0, 0, samples, kChunkFormatPlain);
  std::vector<std::byte> out(1 + blob.size() - kChunkHeaderBytes);
  out[0] = std::byte{1};
  std::copy(blob.begin() + static_cast<std::ptrdiff_t>(kChunkHeaderBytes), blob.end(), out.begin() + 1);
  return out;
}

// A scratch folder per test (tests/testing/scratch_dir.h), with a file helper.
class TempDir : public hapticlab::testing::ScratchDir {
 public:
  TempDir() : hapticlab::testing::ScratchDir("hapticlab_db_") {}
  std::filesystem::path file(const std::string& name) const { return path() / name; }
};

// Damage as a bad disk or a stray write would: one byte of chunk `chunk_id`'s
// blob inverted, through SQLite (read, flip, write back), so the file stays
// a valid database and only the checksum can tell.
inline void flip_chunk_byte(Database& db, std::int64_t chunk_id, std::size_t offset) {
  std::vector<std::byte> blob;
  {
    Statement read = db.prepare("SELECT data FROM sample_chunk WHERE id = ?1");
    read.bind(1, chunk_id);
    if (!read.step()) throw DbError("flip_chunk_byte: no chunk " + std::to_string(chunk_id));
    const std::span<const std::byte> data = read.column_blob(0);
    blob.assign(data.begin(), data.end());
  }
  blob.at(offset) ^= std::byte{0xFF};
  db.prepare("UPDATE sample_chunk SET data = ?2 WHERE id = ?1").bind(1, chunk_id).bind_blob(2, blob).run();
}

// `blob` with its checksum recomputed for `place` as sample_codec.h defines
// it (trial, instrument, first tick, count as 8 bytes each, little-endian,
// then the format byte and the body), written out here apart from the
// codec: what an attack, or a writer that got the body wrong, would store.
inline std::vector<std::byte> resign_blob(std::vector<std::byte> blob, const ChunkPlace& place) {
  std::array<std::byte, 33> head{};
  const auto put = [&](std::size_t at, std::uint64_t v) {
    for (std::size_t i = 0; i < 8; ++i) head[at + i] = static_cast<std::byte>(v >> (8 * i));
  };
  put(0, static_cast<std::uint64_t>(place.trial_id));
  put(8, static_cast<std::uint64_t>(place.instrument));
  put(16, place.first_tick);
  put(24, place.count);
  head[32] = blob.at(0);
  const std::uint32_t crc = crc32c(crc32c(0, head), std::span(blob).subspan(kChunkHeaderBytes));
  for (std::size_t i = 0; i < 4; ++i) blob[1 + i] = static_cast<std::byte>(crc >> (8 * i));
  return blob;
}

// The place of chunk `chunk_id` as its row says.
inline ChunkPlace chunk_place(Database& db, std::int64_t chunk_id) {
  Statement read = db.prepare("SELECT trial_id, instrument, first_tick, count FROM sample_chunk WHERE id = ?1");
  read.bind(1, chunk_id);
  if (!read.step()) throw DbError("chunk_place: no chunk " + std::to_string(chunk_id));
  return {read.column_int64(0), read.column_int64(1), static_cast<std::uint64_t>(read.column_int64(2)),
          static_cast<std::uint64_t>(read.column_int64(3))};
}

// The blob a writer that got it wrong would store, correctly signed: chunk
// `chunk_id`'s data replaced by `format`, a CRC-32C over its row's place,
// the format and `body` (sample_codec.h), then `body`. Only the format's
// own checks can refuse it, not the checksum.
inline void resign_chunk(Database& db, std::int64_t chunk_id, std::uint8_t format, std::span<const std::byte> body) {
  std::vector<std::byte> blob{std::byte{format}, std::byte{0}, std::byte{0}, std::byte{0}, std::byte{0}};
  blob.insert(blob.end(), body.begin(), body.end());
  blob = resign_blob(std::move(blob), chunk_place(db, chunk_id));
  db.prepare("UPDATE sample_chunk SET data = ?2 WHERE id = ?1").bind(1, chunk_id).bind_blob(2, blob).run();
}

// A chunk as schemas 4..6 stored it, for files made as the previous
// HapticLab made them: format 2 (the same preconditioned body in a zstd
// frame without its content checksum) or 1 (`plain`), its checksum over
// first tick, count, format and body only. Built here from today's
// encoder and zstd, not by the library.
inline std::vector<std::byte> schema6_blob(std::span<const StoredSample> samples, bool plain = false) {
  std::vector<std::byte> blob = encode_chunk(0, 0, samples, plain ? kChunkFormatPlain : kChunkFormat);
  if (!plain) {
    const auto frame = std::span(blob).subspan(kChunkHeaderBytes);
    std::vector<std::byte> body(ZSTD_getFrameContentSize(frame.data(), frame.size()));
    ZSTD_decompress(body.data(), body.size(), frame.data(), frame.size());
    std::vector<std::byte> packed(ZSTD_compressBound(body.size()));
    packed.resize(ZSTD_compress(packed.data(), packed.size(), body.data(), body.size(), 1));  // no checksum
    blob.resize(kChunkHeaderBytes);
    blob[0] = std::byte{2};
    blob.insert(blob.end(), packed.begin(), packed.end());
  }
  std::array<std::byte, 17> head{};
  for (std::size_t i = 0; i < 8; ++i) {
    head[i] = static_cast<std::byte>(samples[0].tick >> (8 * i));
    head[8 + i] = static_cast<std::byte>(static_cast<std::uint64_t>(samples.size()) >> (8 * i));
  }
  head[16] = blob[0];
  const std::uint32_t crc = crc32c(crc32c(0, head), std::span(blob).subspan(kChunkHeaderBytes));
  for (std::size_t i = 0; i < 4; ++i) blob[1 + i] = static_cast<std::byte>(crc >> (8 * i));
  return blob;
}

// Every channel distinct and varying with the tick, so a swapped channel,
// instrument or order shows.
inline LoopSample make_sample(std::uint64_t tick, double dt_s = 1e-3) {
  LoopSample s;
  s.tick = tick;
  s.t_s = static_cast<double>(tick) * dt_s;
  s.dt_s = dt_s;
  s.device_status = static_cast<std::int32_t>(tick % 3);
  for (int k = 0; k < 2; ++k) {
    InstrumentSample& v = s.instrument[static_cast<std::size_t>(k)];
    const double x = static_cast<double>(tick) * 1e-3 + k;
    for (std::size_t j = 0; j < 5; ++j) v.raw_position[j] = 0.1 * std::sin(x + 0.1 * static_cast<double>(j));
    for (std::size_t j = 0; j < 3; ++j) {
      const double d = static_cast<double>(j);
      v.degraded_position[j] = 0.1 * std::cos(x + d);
      v.tip_position_m[j] = 0.05 + 0.01 * std::sin(2 * x + d);
      v.tip_velocity_m_per_s[j] = 0.2 * std::cos(3 * x + d);
      v.ve_force_N[j] = 2.0 * std::sin(x * 5 + d);
      v.displayed_force_N[j] = 1.5 * std::sin(x * 7 + d);
      v.joint_force[j] = 0.7 * std::cos(x * 11 + d);
    }
    v.engine_status = static_cast<std::uint32_t>(tick % 5 == 0 ? 8 : 0);
    v.in_contact = tick % 7 < 3;
  }
  return s;
}

// A study with one participant "P01", one setting and one trial; the trial
// is started (running) unless `start` is false. Returns the trial id.
inline std::int64_t make_trial(StudyDb& db, bool start = true, const std::string& setting = "All Degradations") {
  const std::int64_t study = db.add_study({"test study", "{\"study\": \"test\"}", 42, "test"});
  const std::int64_t participant = db.add_participant(study, "P01");
  const std::int64_t setting_id = db.add_setting_json(study, setting, "{}");
  const std::int64_t trial = db.add_trial({participant, "dissection", setting_id, 2, 2, 5});
  if (start) db.start_trial(trial, db.begin_session(participant, "sim", "virtual", 1000.0));
  return trial;
}

}  // namespace hapticlab::db::testing
