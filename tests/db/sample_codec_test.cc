#include "db/sample_codec.h"

#include <array>
#include <bit>
#include <span>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "db_test_util.h"

namespace hapticlab::db {
namespace {

std::vector<StoredSample> instrument_samples(std::uint64_t first, std::size_t n, int instrument, double dt_s = 1e-3) {
  std::vector<StoredSample> out;
  for (std::uint64_t t = first; t < first + n; ++t) {
    const LoopSample s = testing::make_sample(t, dt_s);
    out.push_back({s.tick, s.t_s, s.dt_s, s.device_status, s.instrument[static_cast<std::size_t>(instrument)]});
  }
  return out;
}

std::vector<double> float_channels(const InstrumentSample& v) {
  std::vector<double> out(v.raw_position.begin(), v.raw_position.end());
  for (const auto* a : {&v.degraded_position, &v.tip_position_m, &v.tip_velocity_m_per_s, &v.ve_force_N,
                        &v.displayed_force_N, &v.joint_force})
    out.insert(out.end(), a->begin(), a->end());
  return out;
}

// float32 rounds to nearest: the error is at most half an ulp, 2^-24
// relative (for normal numbers, which all of these are).
void expect_float32_close(const StoredSample& got, const StoredSample& want) {
  const std::vector<double> g = float_channels(got.value), w = float_channels(want.value);
  ASSERT_EQ(g.size(), 23u);
  for (std::size_t c = 0; c < g.size(); ++c)
    EXPECT_LE(std::abs(g[c] - w[c]), std::abs(w[c]) * 0x1p-24) << "tick " << want.tick << " channel " << c;
}

TEST(SampleCodec, RoundTripExactForTimeAndIntegersFloat32BoundForTheRest) {
  // A wandering dt, so t_s is stored per update (not as a running sum).
  std::vector<StoredSample> in = instrument_samples(1000, 777, 1);
  for (std::size_t i = 0; i < in.size(); ++i) in[i].dt_s = 1e-3 * (1.0 + 0.37 * std::sin(static_cast<double>(i)));
  const std::vector<std::byte> blob = encode_chunk(in);
  std::vector<StoredSample> out{StoredSample{}};  // decode appends
  decode_chunk(1000, in.size(), blob, out);
  ASSERT_EQ(out.size(), in.size() + 1);
  for (std::size_t i = 0; i < in.size(); ++i) {
    const StoredSample& g = out[i + 1];
    const StoredSample& w = in[i];
    EXPECT_EQ(g.tick, w.tick);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(g.t_s), std::bit_cast<std::uint64_t>(w.t_s));
    EXPECT_EQ(std::bit_cast<std::uint64_t>(g.dt_s), std::bit_cast<std::uint64_t>(w.dt_s));
    EXPECT_EQ(g.device_status, w.device_status);
    EXPECT_EQ(g.value.engine_status, w.value.engine_status);
    EXPECT_EQ(g.value.in_contact, w.value.in_contact);
    expect_float32_close(g, w);
  }
}

TEST(SampleCodec, RunningSumTimeIsUsedOnlyWhenBitExact) {
  // dt = 2^-10 s: every t is exactly the previous t plus dt.
  std::vector<StoredSample> in = instrument_samples(0, 500, 0, 0x1p-10);
  const std::size_t compact = encode_chunk(in).size();
  // One t off by an ulp: the encoder must fall back to storing every t.
  in[250].t_s = std::nextafter(in[250].t_s, 1.0);
  const std::vector<std::byte> blob = encode_chunk(in);
  EXPECT_EQ(blob.size(), compact + 8 * (in.size() - 1));
  std::vector<StoredSample> out;
  decode_chunk(0, in.size(), blob, out);
  EXPECT_EQ(out[250].t_s, in[250].t_s);
  EXPECT_EQ(out[251].t_s, in[251].t_s);
}

TEST(SampleCodec, ConstantChannelsCollapse) {
  std::vector<StoredSample> in = instrument_samples(0, 1000, 0, 0x1p-10);
  const std::size_t varying = encode_chunk(in).size();
  for (StoredSample& s : in) s.value.ve_force_N = {0.0, 0.0, 0.0};  // out of contact
  EXPECT_EQ(encode_chunk(in).size(), varying - 3 * (1000 - 1) * 4);
}

TEST(SampleCodec, OutOfRangeAndNonFiniteValues) {
  std::vector<StoredSample> in = instrument_samples(0, 3, 0);
  in[0].value.ve_force_N[0] = 1e300;
  in[1].value.ve_force_N[0] = -1e300;
  in[2].value.ve_force_N[0] = std::numeric_limits<double>::quiet_NaN();
  std::vector<StoredSample> out;
  decode_chunk(0, 3, encode_chunk(in), out);
  EXPECT_EQ(out[0].value.ve_force_N[0], std::numeric_limits<double>::infinity());
  EXPECT_EQ(out[1].value.ve_force_N[0], -std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(out[2].value.ve_force_N[0]));
}

std::string hex(const std::vector<std::byte>& b) {
  std::string out;
  char buf[3];
  for (std::byte x : b) {
    std::snprintf(buf, sizeof buf, "%02x", std::to_integer<unsigned>(x));
    out += buf;
  }
  return out;
}

TEST(SampleCodec, GoldenBytesOfATinyChunk) {
  StoredSample a, b;
  a.tick = 5; a.t_s = 1.0; a.dt_s = 0.5; a.device_status = -1;
  b.tick = 6; b.t_s = 1.5; b.dt_s = 0.5; b.device_status = -1;
  a.value.raw_position[0] = 0.25;
  b.value.raw_position[0] = -2.0;
  a.value.engine_status = 1;
  b.value.engine_status = 16;
  b.value.in_contact = true;
  const std::vector<StoredSample> in{a, b};

  // The CRC was worked out apart from the codec (a bitwise CRC-32C in
  // Python over ticks 5 (8 bytes), count 2 (8 bytes), format byte, body).
  std::string golden = "01";                   // format 1
  golden += "5450f027";                        // CRC-32C 0x27f05054
  std::string body = "01" "000000000000e03f";  // dt_s: constant 0.5
  body += "02" "000000000000f03f";           // t_s: running sum from 1.0
  body += "00" "0000803e" "000000c0";        // raw_insertion_m: 0.25f, -2.0f
  for (int c = 0; c < 22; ++c) body += "01" "00000000";  // the other float channels: constant 0
  body += "00" "01000000" "10000000";        // engine_status: 1, 16
  body += "01" "ffffffff";                   // device_status: constant -1
  body += "00" "00" "01";                    // in_contact: 0, 1
  EXPECT_EQ(hex(encode_chunk(in)), golden + body);
  // Schema versions 1..3 wrote the same body behind a lone format byte 1;
  // the migration tests make their old files with legacy_blob().
  EXPECT_EQ(hex(testing::legacy_blob(in)), "01" + body);
}

TEST(SampleCodec, Crc32cOfTheStandardCheckString) {
  // The check value of CRC-32C (Castagnoli) for "123456789" (RFC 3720 B.4's polynomial).
  const std::string text = "123456789";
  EXPECT_EQ(crc32c(0, std::as_bytes(std::span(text))), 0xE3069283u);
  // Continuing a CRC equals one pass over the whole.
  const auto bytes = std::as_bytes(std::span(text));
  EXPECT_EQ(crc32c(crc32c(0, bytes.first(4)), bytes.subspan(4)), 0xE3069283u);
  EXPECT_EQ(crc32c_portable(0, std::as_bytes(std::span(text))), 0xE3069283u);
  // The instruction path (if this CPU has one) and the tables agree at every
  // length and alignment (the 8-byte loops and their byte tails).
  std::vector<std::byte> data(300);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::byte>(i * 37 + 11);
  for (std::size_t start = 0; start < 9; ++start)
    for (std::size_t n = 0; n + start <= data.size(); n += 7)
      EXPECT_EQ(crc32c(5, std::span(data).subspan(start, n)), crc32c_portable(5, std::span(data).subspan(start, n)))
          << start << " " << n;
}

// Every single-byte change anywhere in the blob, or in the row's first tick
// or count, is refused as a checksum mismatch (CRC-32C catches every burst
// of up to 32 bits), and nothing is decoded.
TEST(SampleCodec, EveryChangedByteIsCaughtByTheChecksum) {
  const std::vector<StoredSample> in = instrument_samples(100, 20, 0);
  const std::vector<std::byte> blob = encode_chunk(in);
  std::vector<StoredSample> out;
  for (std::size_t i = 0; i < blob.size(); ++i) {
    for (const unsigned flip : {0x01u, 0x80u, 0xFFu}) {
      std::vector<std::byte> bad = blob;
      bad[i] ^= std::byte(flip);
      try {
        decode_chunk(100, 20, bad, out);
        ADD_FAILURE() << "byte " << i << " xor " << flip << " was decoded";
      } catch (const ChunkError& e) {
        EXPECT_EQ(e.kind(), ChunkError::Kind::kChecksum) << "byte " << i << ": " << e.what();
      }
    }
  }
  EXPECT_TRUE(out.empty());
  EXPECT_THROW(decode_chunk(101, 20, blob, out), ChunkError);  // first_tick column changed
  EXPECT_THROW(verify_chunk(100, 19, blob), ChunkError);       // count column changed
  EXPECT_EQ(verify_chunk(100, 20, blob), kChunkFormat);
}

// A later HapticLab may write format 2 (compressed): its checksum is right,
// and this one must refuse it by number, not misread it.
TEST(SampleCodec, UnknownFormatIsRefusedByNumber) {
  const std::vector<StoredSample> in = instrument_samples(0, 20, 0);
  std::vector<std::byte> blob = encode_chunk(in);
  blob[0] = std::byte{2};
  // Re-sign it as the header comment in sample_codec.h says.
  std::array<std::byte, 17> head{};
  head[8] = std::byte{20};
  head[16] = std::byte{2};
  const std::uint32_t crc = crc32c(crc32c(0, head), std::span(blob).subspan(kChunkHeaderBytes));
  for (int i = 0; i < 4; ++i) blob[static_cast<std::size_t>(1 + i)] = static_cast<std::byte>(crc >> (8 * i));
  std::vector<StoredSample> out;
  try {
    decode_chunk(0, 20, blob, out);
    FAIL() << "format 2 was decoded";
  } catch (const ChunkError& e) {
    EXPECT_EQ(e.kind(), ChunkError::Kind::kUnknownFormat);
    EXPECT_THAT(e.what(), ::testing::HasSubstr("chunk format 2 is not one this HapticLab reads"));
  }
  EXPECT_TRUE(out.empty());
}

// A blob from before schema 4, wrapped by the migration, decodes to the
// same samples as a fresh one, and is protected from then on.
TEST(SampleCodec, MigratedLegacyChunkDecodesAndIsChecked) {
  const std::vector<StoredSample> in = instrument_samples(7, 30, 1);
  std::vector<std::byte> migrated = checksum_legacy_chunk(7, 30, testing::legacy_blob(in));
  EXPECT_EQ(verify_chunk(7, 30, migrated), kChunkFormatMigrated);
  std::vector<StoredSample> fresh, old;
  decode_chunk(7, 30, encode_chunk(in), fresh);
  decode_chunk(7, 30, migrated, old);
  ASSERT_EQ(old.size(), fresh.size());
  for (std::size_t i = 0; i < old.size(); ++i) {
    EXPECT_EQ(old[i].tick, fresh[i].tick);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(old[i].t_s), std::bit_cast<std::uint64_t>(fresh[i].t_s));
    EXPECT_EQ(float_channels(old[i].value), float_channels(fresh[i].value));
  }
  migrated.back() ^= std::byte{1};
  old.clear();
  EXPECT_THROW(decode_chunk(7, 30, migrated, old), ChunkError);
  EXPECT_TRUE(old.empty());
}

TEST(SampleCodec, DamagedBlobsAreRefused) {
  const std::vector<StoredSample> in = instrument_samples(0, 20, 0);
  std::vector<std::byte> blob = encode_chunk(in);
  std::vector<StoredSample> out;
  EXPECT_THROW(decode_chunk(0, 21, blob, out), std::runtime_error);  // count says more
  EXPECT_THROW(decode_chunk(0, 19, blob, out), std::runtime_error);  // count says fewer
  EXPECT_TRUE(out.empty()) << "a refused chunk must not leave partial samples";
  std::vector<std::byte> bad_format = blob;
  bad_format[0] = std::byte{9};
  EXPECT_THAT([&] { decode_chunk(0, 20, bad_format, out); },
              ::testing::ThrowsMessage<ChunkError>(::testing::HasSubstr("checksum mismatch")));
  EXPECT_THROW(decode_chunk(0, 20, std::span(blob).first(4), out), ChunkError);  // shorter than the header
  // A structurally bad body with a right checksum (as a buggy writer could
  // make) is still refused: an unknown tag.
  std::vector<StoredSample> one = instrument_samples(0, 1, 0);
  std::vector<std::byte> legacy = testing::legacy_blob(one);
  legacy[1] = std::byte{7};
  EXPECT_THAT([&] { decode_chunk(0, 1, checksum_legacy_chunk(0, 1, legacy), out); },
              ::testing::ThrowsMessage<ChunkError>(::testing::HasSubstr("unknown tag 7")));
  EXPECT_THROW(decode_chunk(0, std::size_t{1} << 40, blob, out), std::runtime_error);
}

TEST(SampleCodec, EncoderRefusesGapsAndEmptyChunks) {
  std::vector<StoredSample> in = instrument_samples(0, 5, 0);
  in[3].tick = 9;
  EXPECT_THROW(encode_chunk(in), std::invalid_argument);
  EXPECT_THROW(encode_chunk({}), std::invalid_argument);
}

}  // namespace
}  // namespace hapticlab::db
