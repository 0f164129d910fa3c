#include "db/sample_codec.h"

#include <bit>
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

  std::string golden = "01";                   // format 1
  golden += "01" "000000000000e03f";           // dt_s: constant 0.5
  golden += "02" "000000000000f03f";           // t_s: running sum from 1.0
  golden += "00" "0000803e" "000000c0";        // raw_insertion_m: 0.25f, -2.0f
  for (int c = 0; c < 22; ++c) golden += "01" "00000000";  // the other float channels: constant 0
  golden += "00" "01000000" "10000000";        // engine_status: 1, 16
  golden += "01" "ffffffff";                   // device_status: constant -1
  golden += "00" "00" "01";                    // in_contact: 0, 1
  EXPECT_EQ(hex(encode_chunk(in)), golden);
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
              ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr("format 9")));
  std::vector<std::byte> bad_tag = blob;
  bad_tag[1] = std::byte{7};
  EXPECT_THROW(decode_chunk(0, 20, bad_tag, out), std::runtime_error);
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
