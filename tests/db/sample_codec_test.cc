#include "db/sample_codec.h"

#include <array>
#include <bit>
#include <span>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <limits>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zstd.h>

#include "db_test_util.h"

namespace hapticlab::db {
namespace {

// The row every chunk of these tests belongs to (the checksum covers it).
constexpr std::int64_t kTrial = 7;
constexpr int kHand = 1;
ChunkPlace at(std::uint64_t first_tick, std::uint64_t count) { return {kTrial, kHand, first_tick, count}; }

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
  for (const std::uint8_t format : {kChunkFormat, kChunkFormatPlain}) {
  SCOPED_TRACE("format " + std::to_string(format));
  const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in, format);
  std::vector<StoredSample> out{StoredSample{}};  // decode appends
  decode_chunk(at(1000, in.size()), blob, out);
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
}

TEST(SampleCodec, RunningSumTimeIsUsedOnlyWhenBitExact) {
  // dt = 2^-10 s: every t is exactly the previous t plus dt.
  std::vector<StoredSample> in = instrument_samples(0, 500, 0, 0x1p-10);
  const std::size_t compact = encode_chunk(kTrial, kHand, in, kChunkFormatPlain).size();
  // One t off by an ulp: the encoder must fall back to storing every t.
  in[250].t_s = std::nextafter(in[250].t_s, 1.0);
  const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in, kChunkFormatPlain);
  EXPECT_EQ(blob.size(), compact + 8 * (in.size() - 1));
  std::vector<StoredSample> out;
  decode_chunk(at(0, in.size()), blob, out);
  EXPECT_EQ(out[250].t_s, in[250].t_s);
  EXPECT_EQ(out[251].t_s, in[251].t_s);
}

TEST(SampleCodec, ConstantChannelsCollapse) {
  std::vector<StoredSample> in = instrument_samples(0, 1000, 0, 0x1p-10);
  const std::size_t varying = encode_chunk(kTrial, kHand, in, kChunkFormatPlain).size();
  for (StoredSample& s : in) s.value.ve_force_N = {0.0, 0.0, 0.0};  // out of contact
  EXPECT_EQ(encode_chunk(kTrial, kHand, in, kChunkFormatPlain).size(), varying - 3 * (1000 - 1) * 4);
}

TEST(SampleCodec, OutOfRangeAndNonFiniteValues) {
  std::vector<StoredSample> in = instrument_samples(0, 3, 0);
  in[0].value.ve_force_N[0] = 1e300;
  in[1].value.ve_force_N[0] = -1e300;
  in[2].value.ve_force_N[0] = std::numeric_limits<double>::quiet_NaN();
  std::vector<StoredSample> out;
  decode_chunk(at(0, 3), encode_chunk(kTrial, kHand, in), out);
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
  // Python over trial 7, instrument 1, first tick 5, count 2 (8 bytes
  // each, little-endian), the format byte, then the body).
  std::string golden = "01";                   // format 1
  golden += "d064452e";                        // CRC-32C 0x2e4564d0
  std::string body = "01" "000000000000e03f";  // dt_s: constant 0.5
  body += "02" "000000000000f03f";           // t_s: running sum from 1.0
  body += "00" "0000803e" "000000c0";        // raw_insertion_m: 0.25f, -2.0f
  for (int c = 0; c < 22; ++c) body += "01" "00000000";  // the other float channels: constant 0
  body += "00" "01000000" "10000000";        // engine_status: 1, 16
  body += "01" "ffffffff";                   // device_status: constant -1
  body += "00" "00" "01";                    // in_contact: 0, 1
  EXPECT_EQ(hex(encode_chunk(kTrial, kHand, in, kChunkFormatPlain)), golden + body);
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
  const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in);
  std::vector<StoredSample> out;
  for (std::size_t i = 0; i < blob.size(); ++i) {
    for (const unsigned flip : {0x01u, 0x80u, 0xFFu}) {
      std::vector<std::byte> bad = blob;
      bad[i] ^= std::byte(flip);
      try {
        decode_chunk(at(100, 20), bad, out);
        ADD_FAILURE() << "byte " << i << " xor " << flip << " was decoded";
      } catch (const ChunkError& e) {
        EXPECT_EQ(e.kind(), ChunkError::Kind::kChecksum) << "byte " << i << ": " << e.what();
      }
    }
  }
  EXPECT_TRUE(out.empty());
  EXPECT_THROW(decode_chunk(at(101, 20), blob, out), ChunkError);  // first_tick column changed
  EXPECT_THROW(verify_chunk(at(100, 19), blob), ChunkError);       // count column changed
  EXPECT_EQ(verify_chunk(at(100, 20), blob), kChunkFormat);
}

// Where a chunk belongs is in its checksum: the same blob moved to another
// trial, or given to the other instrument (the two instruments' chunks
// swapped), no longer verifies.
TEST(SampleCodec, TheChecksumCoversTrialAndInstrument) {
  const std::vector<StoredSample> in = instrument_samples(100, 20, 0);
  for (const std::uint8_t format : {kChunkFormat, kChunkFormatPlain}) {
    const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in, format);
    EXPECT_EQ(verify_chunk(at(100, 20), blob), format);
    for (const ChunkPlace& moved : {ChunkPlace{kTrial + 1, kHand, 100, 20}, ChunkPlace{kTrial, 1 - kHand, 100, 20},
                                    ChunkPlace{kTrial, 2, 100, 20}}) {
      EXPECT_THAT([&] { verify_chunk(moved, blob); },
                  ::testing::ThrowsMessage<ChunkError>(::testing::HasSubstr("checksum mismatch")))
          << "trial " << moved.trial_id << " instrument " << moved.instrument;
    }
  }
}

// A later HapticLab may write format 4: its checksum is right, and this one
// must refuse it by number, not misread it. Format 2 (schemas 4..6) is
// converted by the migration, so one in a current file is damage.
TEST(SampleCodec, UnknownFormatIsRefusedByNumber) {
  const std::vector<StoredSample> in = instrument_samples(0, 20, 0);
  std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in);
  blob[0] = std::byte{4};
  std::vector<StoredSample> out;
  try {
    decode_chunk(at(0, 20), testing::resign_blob(blob, at(0, 20)), out);
    FAIL() << "format 4 was decoded";
  } catch (const ChunkError& e) {
    EXPECT_EQ(e.kind(), ChunkError::Kind::kUnknownFormat);
    EXPECT_THAT(e.what(), ::testing::HasSubstr("chunk format 4 is not one this HapticLab reads (0, 1, 3)"));
  }
  blob[0] = std::byte{2};
  EXPECT_THAT([&] { decode_chunk(at(0, 20), testing::resign_blob(blob, at(0, 20)), out); },
              ::testing::ThrowsMessage<ChunkError>(::testing::HasSubstr("chunk format 2 (a zstd frame without its "
                                                                        "content checksum) belongs to schemas 4..6")));
  EXPECT_TRUE(out.empty());
}

// A blob from before schema 4, wrapped by the migration, decodes to the
// same samples as a fresh one, and is protected from then on.
TEST(SampleCodec, MigratedLegacyChunkDecodesAndIsChecked) {
  const std::vector<StoredSample> in = instrument_samples(7, 30, 1);
  // Schema 4's step, then schema 7's: the bytes kept, the checksum renewed.
  const std::vector<std::byte> legacy = testing::legacy_blob(in);
  std::vector<std::byte> migrated = upgrade_schema6_chunk(at(7, 30), checksum_legacy_chunk(7, 30, legacy));
  EXPECT_EQ(verify_chunk(at(7, 30), migrated), kChunkFormatMigrated);
  EXPECT_TRUE(std::equal(legacy.begin(), legacy.end(), migrated.begin() + kChunkHeaderBytes));
  std::vector<StoredSample> fresh, old;
  decode_chunk(at(7, 30), encode_chunk(kTrial, kHand, in), fresh);
  decode_chunk(at(7, 30), migrated, old);
  ASSERT_EQ(old.size(), fresh.size());
  for (std::size_t i = 0; i < old.size(); ++i) {
    EXPECT_EQ(old[i].tick, fresh[i].tick);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(old[i].t_s), std::bit_cast<std::uint64_t>(fresh[i].t_s));
    EXPECT_EQ(float_channels(old[i].value), float_channels(fresh[i].value));
  }
  migrated.back() ^= std::byte{1};
  old.clear();
  EXPECT_THROW(decode_chunk(at(7, 30), migrated, old), ChunkError);
  EXPECT_TRUE(old.empty());
}

TEST(SampleCodec, DamagedBlobsAreRefused) {
  const std::vector<StoredSample> in = instrument_samples(0, 20, 0);
  std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in);
  std::vector<StoredSample> out;
  EXPECT_THROW(decode_chunk(at(0, 21), blob, out), std::runtime_error);  // count says more
  EXPECT_THROW(decode_chunk(at(0, 19), blob, out), std::runtime_error);  // count says fewer
  EXPECT_TRUE(out.empty()) << "a refused chunk must not leave partial samples";
  std::vector<std::byte> bad_format = blob;
  bad_format[0] = std::byte{9};
  EXPECT_THAT([&] { decode_chunk(at(0, 20), bad_format, out); },
              ::testing::ThrowsMessage<ChunkError>(::testing::HasSubstr("checksum mismatch")));
  EXPECT_THROW(decode_chunk(at(0, 20), std::span(blob).first(4), out), ChunkError);  // shorter than the header
  // A structurally bad body with a right checksum (as a buggy writer could
  // make) is still refused: an unknown tag.
  std::vector<StoredSample> one = instrument_samples(0, 1, 0);
  std::vector<std::byte> plain = encode_chunk(kTrial, kHand, one, kChunkFormatPlain);
  plain[kChunkHeaderBytes] = std::byte{7};
  EXPECT_THAT([&] { decode_chunk(at(0, 1), testing::resign_blob(plain, at(0, 1)), out); },
              ::testing::ThrowsMessage<ChunkError>(::testing::HasSubstr("unknown tag 7")));
  // So is one the schema 7 migration would have to certify.
  std::vector<std::byte> legacy = testing::legacy_blob(one);
  legacy[1] = std::byte{7};
  EXPECT_THAT([&] { upgrade_schema6_chunk(at(0, 1), checksum_legacy_chunk(0, 1, legacy)); },
              ::testing::ThrowsMessage<ChunkError>(::testing::HasSubstr("unknown tag 7")));
  EXPECT_THROW(decode_chunk(at(0, std::size_t{1} << 40), blob, out), std::runtime_error);
}

// Format 3 stores the same bits as format 1, for smooth signals and for the
// values a float pattern delta could trip on: NaN with a payload, ±inf,
// -0.0, subnormals, sign changes, and a dt that wanders (t_s per update).
TEST(SampleCodec, FormatThreeDecodesBitIdenticalToFormatOne) {
  std::vector<StoredSample> in = instrument_samples(50, 1000, 1);
  for (std::size_t i = 0; i < in.size(); ++i) {
    const double x = static_cast<double>(i);
    in[i].dt_s = 1e-3 * (1.0 + 0.01 * std::sin(0.3 * x));
    in[i].value.tip_position_m = {0.01 * std::sin(x / 200), -0.02 + 1e-5 * x, 0.1};
    in[i].value.ve_force_N[2] = i % 100 < 50 ? 0.0 : -0.0;
  }
  in[3].value.raw_position[0] = std::numeric_limits<double>::quiet_NaN();
  in[4].value.raw_position[0] = -std::numeric_limits<double>::infinity();
  in[5].value.raw_position[0] = std::numeric_limits<double>::infinity();
  in[6].value.raw_position[0] = std::numeric_limits<double>::denorm_min();
  in[7].value.raw_position[0] = -1e-42;  // a float32 subnormal
  in[8].value.raw_position[0] = std::numeric_limits<float>::max();
  in[9].value.engine_status = 0xFFFFFFFFu;
  in[10].device_status = std::numeric_limits<std::int32_t>::min();
  std::vector<StoredSample> plain, packed;
  decode_chunk(at(50, in.size()), encode_chunk(kTrial, kHand, in, kChunkFormatPlain), plain);
  const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in);
  ASSERT_EQ(verify_chunk(at(50, in.size()), blob), kChunkFormat);
  decode_chunk(at(50, in.size()), blob, packed);
  ASSERT_EQ(packed.size(), plain.size());
  for (std::size_t i = 0; i < plain.size(); ++i) {
    EXPECT_EQ(packed[i].tick, plain[i].tick);
    EXPECT_EQ(std::bit_cast<std::uint64_t>(packed[i].t_s), std::bit_cast<std::uint64_t>(plain[i].t_s)) << i;
    EXPECT_EQ(std::bit_cast<std::uint64_t>(packed[i].dt_s), std::bit_cast<std::uint64_t>(plain[i].dt_s)) << i;
    EXPECT_EQ(packed[i].device_status, plain[i].device_status);
    EXPECT_EQ(packed[i].value.engine_status, plain[i].value.engine_status);
    EXPECT_EQ(packed[i].value.in_contact, plain[i].value.in_contact);
    const std::vector<double> a = float_channels(packed[i].value), b = float_channels(plain[i].value);
    for (std::size_t c = 0; c < a.size(); ++c)
      EXPECT_EQ(std::bit_cast<std::uint64_t>(a[c]), std::bit_cast<std::uint64_t>(b[c])) << i << " " << c;
  }
  // Smooth channels compress: well under half of format 1 here.
  EXPECT_LT(blob.size(), encode_chunk(kTrial, kHand, in, kChunkFormatPlain).size() / 2);
}

// The preconditioning worked by hand on the golden chunk above: the frame
// decompresses to format 1's body with each per-update 4-byte channel as
// differences, byte planes first-byte-first.
TEST(SampleCodec, FormatThreeGoldenPreconditionedBody) {
  StoredSample a, b;
  a.tick = 5; a.t_s = 1.0; a.dt_s = 0.5; a.device_status = -1;
  b.tick = 6; b.t_s = 1.5; b.dt_s = 0.5; b.device_status = -1;
  a.value.raw_position[0] = 0.25;   // 0x3e800000
  b.value.raw_position[0] = -2.0;   // 0xc0000000; difference 0x81800000
  a.value.engine_status = 1;
  b.value.engine_status = 16;       // difference 15
  b.value.in_contact = true;
  const std::vector<StoredSample> in{a, b};
  const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in);
  ASSERT_EQ(std::to_integer<int>(blob[0]), 3);
  const auto frame = std::span(blob).subspan(kChunkHeaderBytes);
  std::vector<std::byte> body(ZSTD_getFrameContentSize(frame.data(), frame.size()));
  ASSERT_EQ(ZSTD_decompress(body.data(), body.size(), frame.data(), frame.size()), body.size());
  std::string want = "01" "000000000000e03f" "02" "000000000000f03f";
  // Fewer than 8 updates: no bit planes, the differences as they are.
  want += "00" "0000803e" "00008081";  // raw_insertion_m: 0x3e800000, then 0xc0000000 - 0x3e800000
  for (int c = 0; c < 22; ++c) want += "01" "00000000";
  want += "00" "01000000" "0f000000";  // engine_status: 1, then 16 - 1
  want += "01" "ffffffff" "00" "00" "01";
  EXPECT_EQ(hex(body), want);
  std::vector<StoredSample> out;
  decode_chunk(at(5, 2), blob, out);
  EXPECT_EQ(out[1].value.raw_position[0], -2.0);
  EXPECT_EQ(out[1].value.engine_status, 16u);
}

// Bit planes worked by hand: raw_insertion_m steps through the 8 floats
// from 1.0f (0x3f800000, 0x3f800001, ...), so its differences are
// 0x3f800000 and then 1 seven times. Plane k holds bit k % 8 of byte k / 8
// of each difference, value i at bit i: plane 0 (bit 0 of byte 0) is
// 0b11111110, plane 23 (bit 7 of byte 2, 0x80) and planes 24..29 (bits 0-5
// of byte 3, 0x3f) are 0b00000001, all others 0.
TEST(SampleCodec, FormatThreeGoldenBitPlanes) {
  std::vector<StoredSample> in(8);
  for (std::size_t i = 0; i < 8; ++i) {
    in[i].tick = i;
    in[i].dt_s = 0.5;
    in[i].t_s = 1.0 + 0.5 * static_cast<double>(i);
    in[i].device_status = -1;
    in[i].value.raw_position[0] = double{std::bit_cast<float>(0x3f800000u + static_cast<std::uint32_t>(i))};
  }
  const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in);
  const auto frame = std::span(blob).subspan(kChunkHeaderBytes);
  std::vector<std::byte> body(ZSTD_getFrameContentSize(frame.data(), frame.size()));
  ASSERT_EQ(ZSTD_decompress(body.data(), body.size(), frame.data(), frame.size()), body.size());
  std::string planes = "fe" + std::string(2 * 22, '0') + "01" + std::string("010101010101") + "0000";
  std::string want = "01" "000000000000e03f" "02" "000000000000f03f" "00" + planes;
  for (int c = 0; c < 22; ++c) want += "01" "00000000";
  want += "01" "00000000" "01" "ffffffff" "01" "00";
  EXPECT_EQ(hex(body), want);
  std::vector<StoredSample> out;
  decode_chunk(at(0, 8), blob, out);
  for (std::size_t i = 0; i < 8; ++i) EXPECT_EQ(out[i].value.raw_position[0], in[i].value.raw_position[0]) << i;
}

// Differences of n values' bit patterns (the first kept), in bit planes by
// the definition of sample_codec.h, one bit at a time: bit k of value i
// (bit k % 8 of its byte k / 8) at bit i % 8 of byte i / 8 of plane k; the
// last n % 8 differences follow as they are.
template <typename U>
std::vector<std::byte> planes_by_definition(const std::byte* values, std::size_t n) {
  constexpr std::size_t kWidth = sizeof(U);
  std::vector<U> d(n);
  U prev = 0;
  for (std::size_t i = 0; i < n; ++i) {
    U x;
    std::memcpy(&x, values + i * kWidth, kWidth);
    d[i] = static_cast<U>(x - prev);
    prev = x;
  }
  const std::size_t m = n - n % 8;
  std::vector<std::byte> out(n * kWidth, std::byte{0});
  for (std::size_t k = 0; k < 8 * kWidth; ++k)
    for (std::size_t i = 0; i < m; ++i)
      if ((d[i] >> k) & 1u) out[k * (m / 8) + i / 8] |= static_cast<std::byte>(1u << (i % 8));
  std::memcpy(out.data() + m * kWidth, d.data() + m, (n - m) * kWidth);
  return out;
}

// Bit planes of long chunks against their definition, for lengths with and
// without values past the last group of 8: random dt_s (8 bytes; t_s its
// running sum) and raw_insertion_m (4 bytes, any finite float32 of either
// sign), every other channel constant. The frame must hold the plain body
// with those two channels' values replaced by their planes.
TEST(SampleCodec, FormatThreeBitPlanesFollowTheirDefinitionForAnyLength) {
  std::mt19937_64 rng(7);
  // 64, 128, 191, 200, 1000: the decoder's 8- and 16-group blocks (SSE2)
  // with and without groups and values left over; 256, 263, 520, 1000: its
  // 32-group blocks (AVX2, where the CPU has it) alone and with the others.
  for (std::size_t n : {8u, 9u, 16u, 23u, 64u, 128u, 191u, 200u, 256u, 263u, 520u, 1000u, 1003u}) {
    std::vector<StoredSample> in(n);
    for (std::size_t i = 0; i < n; ++i) {
      in[i].tick = i;
      in[i].dt_s = 1e-3 * (1.0 + std::ldexp(static_cast<double>(rng() >> 11), -53));
      in[i].t_s = i == 0 ? 1.0 : in[i - 1].t_s + in[i].dt_s;
      in[i].device_status = -1;
      // Bit 30 clear: the exponent is below all ones, so never NaN or infinity.
      in[i].value.raw_position[0] = double{std::bit_cast<float>(static_cast<std::uint32_t>(rng()) & 0xBFFFFFFFu)};
    }
    const std::vector<std::byte> plain = encode_chunk(kTrial, kHand, in, kChunkFormatPlain);
    const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in);
    const auto frame = std::span(blob).subspan(kChunkHeaderBytes);
    std::vector<std::byte> body(ZSTD_getFrameContentSize(frame.data(), frame.size()));
    ASSERT_EQ(ZSTD_decompress(body.data(), body.size(), frame.data(), frame.size()), body.size());

    // The plain body: dt's tag and n values, t's running-sum tag and t[0],
    // raw_insertion_m's tag and n values, then the constants.
    std::vector<std::byte> want(plain.begin() + kChunkHeaderBytes, plain.end());
    ASSERT_EQ(std::to_integer<int>(want[0]), 0) << "dt_s per update";
    ASSERT_EQ(std::to_integer<int>(want[1 + 8 * n]), 2) << "t_s a running sum";
    ASSERT_EQ(std::to_integer<int>(want[10 + 8 * n]), 0) << "raw_insertion_m per update";
    const std::vector<std::byte> dt = planes_by_definition<std::uint64_t>(want.data() + 1, n);
    const std::vector<std::byte> raw = planes_by_definition<std::uint32_t>(want.data() + 11 + 8 * n, n);
    std::copy(dt.begin(), dt.end(), want.begin() + 1);
    std::copy(raw.begin(), raw.end(), want.begin() + 11 + static_cast<std::ptrdiff_t>(8 * n));
    EXPECT_EQ(hex(body), hex(want)) << n << " updates";

    std::vector<StoredSample> out;
    decode_chunk(at(0, n), blob, out);
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_EQ(std::bit_cast<std::uint64_t>(out[i].dt_s), std::bit_cast<std::uint64_t>(in[i].dt_s)) << i;
      ASSERT_EQ(std::bit_cast<std::uint64_t>(out[i].value.raw_position[0]),
                std::bit_cast<std::uint64_t>(in[i].value.raw_position[0]))
          << i;
    }
  }
}

// A format-3 chunk whose checksum is right but whose frame does not
// decompress (a writer that got it wrong) is refused like damage.
TEST(SampleCodec, AFrameThatDoesNotDecompressIsRefused) {
  const std::vector<StoredSample> in = instrument_samples(0, 20, 0);
  const std::vector<std::byte> good = encode_chunk(kTrial, kHand, in);
  const auto sign = [](const std::vector<std::byte>& blob) { return testing::resign_blob(blob, at(0, 20)); };
  std::vector<std::byte> garbage(good.begin(), good.begin() + kChunkHeaderBytes);
  for (char c : std::string("not a zstd frame")) garbage.push_back(static_cast<std::byte>(c));
  std::vector<std::byte> cut(good.begin(), good.end() - 3);  // the frame's end missing
  std::vector<StoredSample> out;
  for (const auto& bad : {sign(garbage), sign(cut)}) {
    try {
      decode_chunk(at(0, 20), bad, out);
      ADD_FAILURE() << "decoded";
    } catch (const ChunkError& e) {
      EXPECT_EQ(e.kind(), ChunkError::Kind::kStructure);
      EXPECT_THAT(e.what(), ::testing::HasSubstr("the zstd frame does not decompress"));
    }
  }
  EXPECT_TRUE(out.empty());
}

// The zstd frame proves its own content: a byte changed anywhere in it,
// with the chunk's CRC recomputed (so only the frame can tell), never
// decodes to other values -- it is refused, or (a bit zstd ignores, such as
// the header's unused bit) decodes to exactly the same samples. Without the
// frame's content checksum most such bytes decoded to different numbers
// (issue 34: 4 of 5 positions).
TEST(SampleCodec, AByteChangedInsideTheFrameWithItsCrcRecomputedNeverDecodesToOtherValues) {
  const std::vector<StoredSample> in = instrument_samples(0, 100, 0);
  const std::vector<std::byte> good = encode_chunk(kTrial, kHand, in);
  const auto frame = std::span(good).subspan(kChunkHeaderBytes);
  ASSERT_NE(std::to_integer<int>(frame[4]) & 0x04, 0) << "the frame header's Content_Checksum_flag";
  std::vector<StoredSample> want, out;
  decode_chunk(at(0, 100), good, want);
  const auto same = [&] {
    for (std::size_t i = 0; i < want.size(); ++i)
      if (std::bit_cast<std::uint64_t>(out[i].t_s) != std::bit_cast<std::uint64_t>(want[i].t_s) ||
          float_channels(out[i].value) != float_channels(want[i].value) ||
          out[i].value.engine_status != want[i].value.engine_status || out[i].device_status != want[i].device_status)
        return false;
    return out.size() == want.size();
  };
  std::size_t refused = 0, unchanged = 0;
  for (std::size_t i = kChunkHeaderBytes; i < good.size(); ++i) {
    std::vector<std::byte> bad = good;
    bad[i] ^= std::byte{0x10};
    out.clear();
    try {
      decode_chunk(at(0, 100), testing::resign_blob(bad, at(0, 100)), out);
      EXPECT_TRUE(same()) << "frame byte " << i - kChunkHeaderBytes << " changed and decoded to other values";
      ++unchanged;
    } catch (const ChunkError& e) {
      EXPECT_EQ(e.kind(), ChunkError::Kind::kStructure) << e.what();
      EXPECT_TRUE(out.empty());
      ++refused;
    }
  }
  EXPECT_GT(refused, 50 * unchanged) << refused << " refused, " << unchanged << " harmless";
}

// One frame and nothing else, stating a size the count can take, with its
// content checksum: checked before anything is decompressed.
TEST(SampleCodec, OnlyOneChecksummedFrameOfAPlausibleSizeIsRead) {
  const std::vector<StoredSample> in = instrument_samples(0, 20, 0);
  const std::vector<std::byte> good = encode_chunk(kTrial, kHand, in);
  const auto body = [&](const std::vector<std::byte>& plain, int checksum) {
    ZSTD_CCtx* c = ZSTD_createCCtx();
    ZSTD_CCtx_setParameter(c, ZSTD_c_checksumFlag, checksum);
    std::vector<std::byte> out(ZSTD_compressBound(plain.size()));
    out.resize(ZSTD_compress2(c, out.data(), out.size(), plain.data(), plain.size()));
    ZSTD_freeCCtx(c);
    return out;
  };
  const auto chunk = [&](const std::vector<std::byte>& frame_bytes) {
    std::vector<std::byte> blob(good.begin(), good.begin() + kChunkHeaderBytes);
    blob.insert(blob.end(), frame_bytes.begin(), frame_bytes.end());
    return testing::resign_blob(blob, at(0, 20));
  };
  const std::vector<std::byte> frame(good.begin() + kChunkHeaderBytes, good.end());
  std::vector<std::byte> plain(ZSTD_getFrameContentSize(frame.data(), frame.size()));
  ASSERT_EQ(ZSTD_decompress(plain.data(), plain.size(), frame.data(), frame.size()), plain.size());
  std::vector<StoredSample> out;
  decode_chunk(at(0, 20), chunk(body(plain, 1)), out);  // a frame made apart: read
  ASSERT_EQ(out.size(), 20u);

  struct Case {
    const char* what;
    std::vector<std::byte> frame;
    const char* message;
  };
  std::vector<std::byte> two = frame, empty_after = frame;
  const std::vector<std::byte> second = body(plain, 1), empty = body({}, 1);
  two.insert(two.end(), second.begin(), second.end());
  empty_after.insert(empty_after.end(), empty.begin(), empty.end());
  // 20 updates take at most 28 + 20 * 117 bytes; a frame of 1 MB of zeros
  // states more (a bomb: 2 GiB in 64 kB would do the same).
  const std::vector<std::byte> bomb = body(std::vector<std::byte>(1 << 20), 1);
  for (const Case& c : {Case{"a second frame", two, "bytes follow the zstd frame"},
                        Case{"an empty second frame", empty_after, "bytes follow the zstd frame"},
                        Case{"no content checksum", body(plain, 0), "carries no content checksum"},
                        Case{"more than the count can take", bomb, "more than the 2368 that the row's count"}}) {
    EXPECT_THAT([&] { decode_chunk(at(0, 20), chunk(c.frame), out); },
                ::testing::ThrowsMessage<ChunkError>(::testing::HasSubstr(c.message)))
        << c.what;
  }
  EXPECT_EQ(out.size(), 20u);
}

// A ChunkDecoder gives the same samples read in windows of any size, in
// order or not, as decoded whole: the running-sum t_s carried from one
// window to the next.
TEST(SampleCodec, ChunkDecoderReadsAnyWindowAsTheWhole) {
  std::vector<StoredSample> wall = instrument_samples(40, 1000, 0);
  for (std::size_t i = 0; i < wall.size(); ++i) wall[i].dt_s = 1e-3 * (1.0 + 0.37 * std::sin(static_cast<double>(i)));
  for (const auto& in : {instrument_samples(40, 1000, 0, 0x1p-10), wall}) {
    const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in);
    std::vector<StoredSample> whole;
    decode_chunk(at(40, 1000), blob, whole);
    ChunkDecoder decoder;
    decoder.load(at(40, 1000), blob);
    ASSERT_EQ(decoder.size(), 1000u);
    for (const std::size_t window : {1u, 7u, 64u, 999u, 1000u}) {
      std::vector<StoredSample> got(1000);
      for (std::size_t begin = 0; begin < 1000; begin += window)
        decoder.read(begin, std::min<std::size_t>(begin + window, 1000), got.data() + begin);
      // And once more out of order: the tail, then the head.
      std::vector<StoredSample> tail(10), head(10);
      decoder.read(990, 1000, tail.data());
      decoder.read(0, 10, head.data());
      for (std::size_t i = 0; i < 1000; ++i) {
        ASSERT_EQ(got[i].tick, whole[i].tick) << window;
        ASSERT_EQ(std::bit_cast<std::uint64_t>(got[i].t_s), std::bit_cast<std::uint64_t>(whole[i].t_s))
            << "window " << window << " update " << i;
        ASSERT_EQ(float_channels(got[i].value), float_channels(whole[i].value));
      }
      EXPECT_EQ(std::bit_cast<std::uint64_t>(tail[9].t_s), std::bit_cast<std::uint64_t>(whole[999].t_s));
      EXPECT_EQ(std::bit_cast<std::uint64_t>(head[3].t_s), std::bit_cast<std::uint64_t>(whole[3].t_s));
    }
  }
}

// Column projection: a decoder loaded for some channels gives exactly the
// whole decode's values of those (and of what they are computed from: the
// running-sum t_s needs dt_s, a residual dt_s needs t_s), and leaves every
// other field of its output as it was.
TEST(SampleCodec, ChunkDecoderDecodesTheChannelsAskedForAndLeavesTheRestAlone) {
  std::vector<StoredSample> wall = instrument_samples(40, 1000, 0);
  for (std::size_t i = 0; i < wall.size(); ++i) wall[i].dt_s = 1e-3 * (1.0 + 0.37 * std::sin(static_cast<double>(i)));
  const std::vector<StoredSample> virtual_clock = instrument_samples(40, 1000, 0, 0x1p-10);
  constexpr double kUntouched = 12345.0;
  const ChannelSet t = channel_range(kChannelT, 1), dt = channel_range(kChannelDt, 1);
  const ChannelSet tip = channel_range(kChannelTipFirst, 3), force = channel_range(kChannelVeForceFirst, 3);
  for (const bool running_sum : {true, false}) {
    const std::vector<StoredSample>& in = running_sum ? virtual_clock : wall;
    const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in);
    std::vector<StoredSample> whole;
    decode_chunk(at(40, 1000), blob, whole);
    for (const ChannelSet asked : {t, dt, tip | force, force, channel_range(kChannelRawFirst, 3) | t}) {
      ChunkDecoder decoder;
      decoder.load(at(40, 1000), blob, asked);
      // What comes along: dt_s for a running-sum t_s, t_s for a residual dt_s (the wall clock's).
      const ChannelSet want = asked | ((asked & t) != 0 && running_sum ? dt : 0) |
                              ((asked & dt) != 0 && !running_sum ? t : 0);
      EXPECT_EQ(decoder.channels(), want) << running_sum << " " << asked;
      StoredSample blank;
      blank.t_s = blank.dt_s = kUntouched;
      for (double* x : {&blank.value.raw_position[0], &blank.value.raw_position[4], &blank.value.tip_position_m[0],
                        &blank.value.ve_force_N[2], &blank.value.displayed_force_N[1], &blank.value.joint_force[0]})
        *x = kUntouched;
      std::vector<StoredSample> got(1000, blank);
      decoder.read(0, 1000, got.data());
      const auto same = [](double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); };
      const auto check = [&](ChannelSet channel, double got_value, double whole_value, const char* name, std::size_t i) {
        if ((want & channel) != 0) {
          ASSERT_TRUE(same(got_value, whole_value)) << name << " update " << i << " asked " << asked;
        } else {
          ASSERT_EQ(got_value, kUntouched) << name << " update " << i << " asked " << asked;
        }
      };
      for (std::size_t i = 0; i < 1000; ++i) {
        ASSERT_EQ(got[i].tick, whole[i].tick);
        check(t, got[i].t_s, whole[i].t_s, "t_s", i);
        check(dt, got[i].dt_s, whole[i].dt_s, "dt_s", i);
        check(channel_range(kChannelRawFirst, 1), got[i].value.raw_position[0], whole[i].value.raw_position[0], "raw 0", i);
        check(channel_range(kChannelRawFirst + 4, 1), got[i].value.raw_position[4], whole[i].value.raw_position[4], "raw 4", i);
        check(tip, got[i].value.tip_position_m[0], whole[i].value.tip_position_m[0], "tip x", i);
        check(force, got[i].value.ve_force_N[2], whole[i].value.ve_force_N[2], "ve force z", i);
        check(channel_range(kChannelDisplayedForceFirst, 3), got[i].value.displayed_force_N[1],
              whole[i].value.displayed_force_N[1], "displayed force y", i);
        check(channel_range(kChannelJointForceFirst, 3), got[i].value.joint_force[0], whole[i].value.joint_force[0],
              "joint force 0", i);
      }
    }
  }
}

// The columns (ChunkDecoder::column, read_t) are the values read() gives,
// to the bit, from any first update: per-update and constant float
// channels, t_s stored per update (the wall clock's) and as a running sum
// (carried across windows, also out of order), in format 3 and format 1.
TEST(SampleCodec, ChunkDecoderColumnsAreWhatReadGives) {
  std::vector<StoredSample> wall = instrument_samples(40, 1000, 0);
  for (std::size_t i = 0; i < wall.size(); ++i) {
    wall[i].dt_s = 1e-3 * (1.0 + 0.37 * std::sin(static_cast<double>(i)));
    wall[i].value.displayed_force_N = {0.5, -0.25, 0.0};  // stored once
  }
  const auto same = [](double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); };
  for (const auto& in : {instrument_samples(40, 1000, 0, 0x1p-10), wall}) {
    for (const std::uint8_t format : {kChunkFormat, kChunkFormatPlain}) {
      const std::vector<std::byte> blob = encode_chunk(kTrial, kHand, in, format);
      std::vector<StoredSample> whole;
      decode_chunk(at(40, 1000), blob, whole);
      ChunkDecoder decoder;
      decoder.load(at(40, 1000), blob);
      for (const std::size_t begin : {0u, 333u, 999u, 5u}) {  // the last out of order
        const std::size_t end = std::min<std::size_t>(begin + 400, 1000);
        std::vector<double> t(end - begin);
        decoder.read_t(begin, end, t.data());
        for (std::size_t i = begin; i < end; ++i) {
          ASSERT_TRUE(same(t[i - begin], whole[i].t_s)) << "t_s update " << i << " from " << begin;
          const std::vector<double> want = float_channels(whole[i].value);
          for (std::size_t c = kChannelRawFirst; c < kChannelEngineStatus; ++c)
            ASSERT_TRUE(same(decoder.column(c, begin)[i - begin], want[c - kChannelRawFirst]))
                << kChannelNames[c] << " update " << i << " from " << begin << " format " << int{format};
        }
      }
    }
  }
}

TEST(SampleCodec, EncoderRefusesGapsAndEmptyChunks) {
  std::vector<StoredSample> in = instrument_samples(0, 5, 0);
  in[3].tick = 9;
  EXPECT_THROW(encode_chunk(kTrial, kHand, in), std::invalid_argument);
  EXPECT_THROW(encode_chunk(kTrial, kHand, std::span<const StoredSample>{}), std::invalid_argument);
}

}  // namespace
}  // namespace hapticlab::db
