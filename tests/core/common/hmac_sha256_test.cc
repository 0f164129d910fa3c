// SHA-256 against the FIPS 180-4 examples (NIST's "SHA256.pdf" and
// "SHA2_Additional.pdf"), HMAC-SHA-256 against RFC 4231's test cases 1-7,
// and the properties the UDP bridge leans on: any split of a message into
// update() calls, and verify() refusing every changed bit of message or tag.
#include "core/common/hmac_sha256.h"

#include <string>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

#include "core/common/sha256.h"

namespace hapticlab {
namespace {

std::span<const std::byte> bytes_of(std::string_view s) { return std::as_bytes(std::span(s.data(), s.size())); }

std::string hex_of(std::span<const std::byte> d) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (std::byte b : d) {
    out += kDigits[std::to_integer<unsigned>(b) >> 4];
    out += kDigits[std::to_integer<unsigned>(b) & 15];
  }
  return out;
}

std::string sha256_hex(std::string_view s) { return hex_of(Sha256::hash(bytes_of(s))); }

TEST(Sha256Test, FipsExamples) {
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  // 448 bits: the length field no longer fits the block, padding adds one.
  EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(sha256_hex("abcdefghbcdefghicdefghijdefghijkefghijklfghijklmghijklmnhijklmnoijklmnopjklmnopqklmnopqrlmnopqrsmnop"
                       "qrstnopqrstu"),
            "cf5b16a778af8380036ce59e7b0492370b249b11e8f07a51afac45037afee9d1");
  // One million 'a', fed in pieces of 997 bytes (not a block multiple).
  const std::string chunk(997, 'a');
  Sha256 h;
  std::size_t left = 1'000'000;
  for (; left >= chunk.size(); left -= chunk.size()) h.update(bytes_of(chunk));
  h.update(bytes_of(std::string_view(chunk).substr(0, left)));
  h.update({});  // nothing, from a null pointer
  EXPECT_EQ(hex_of(h.finish()), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256Test, AnySplitIntoUpdatesGivesTheOneShotDigest) {
  std::string message;
  for (int i = 0; i < 200; ++i) message += static_cast<char>(i * 37 + 11);
  for (std::size_t length : {0u, 1u, 55u, 56u, 63u, 64u, 65u, 119u, 120u, 128u, 200u}) {
    const std::string_view m = std::string_view(message).substr(0, length);
    const Sha256::Digest whole = Sha256::hash(bytes_of(m));
    for (std::size_t cut = 0; cut <= length; ++cut) {
      Sha256 h;
      h.update(bytes_of(m.substr(0, cut)));
      h.update(bytes_of(m.substr(cut)));
      ASSERT_EQ(h.finish(), whole) << "length " << length << " cut at " << cut;
    }
  }
}

struct Rfc4231Case {
  std::string key, data, mac_hex;  // mac_hex may be truncated (case 5)
};

TEST(HmacSha256Test, Rfc4231TestCases) {
  const std::string rfc_key_4 = [] {
    std::string k;
    for (int i = 1; i <= 25; ++i) k += static_cast<char>(i);
    return k;
  }();
  const std::vector<Rfc4231Case> cases = {
      {std::string(20, '\x0b'), "Hi There", "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7"},
      {"Jefe", "what do ya want for nothing?", "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843"},
      {std::string(20, '\xaa'), std::string(50, '\xdd'),
       "773ea91e36800e46854db8ebd09181a72959098b3ef8c122d9635514ced565fe"},
      {rfc_key_4, std::string(50, '\xcd'), "82558a389a443c0ea4cc819899f2083a85f0faa3e578f8077a2e3ff46729665b"},
      {std::string(20, '\x0c'), "Test With Truncation", "a3b6167473100ee06e0c796c2955552b"},
      // Keys longer than the block are hashed first.
      {std::string(131, '\xaa'), "Test Using Larger Than Block-Size Key - Hash Key First",
       "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54"},
      {std::string(131, '\xaa'),
       "This is a test using a larger than block-size key and a larger than block-size data. The key needs to be "
       "hashed before being used by the HMAC algorithm.",
       "9b09ffa71b942fcb27635fbcd5b0e944bfdc63644f0713938a7f51535c3a35e2"},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const Rfc4231Case& c = cases[i];
    const HmacSha256 hmac(bytes_of(c.key));
    const Sha256::Digest d = hmac.mac(bytes_of(c.data));
    EXPECT_EQ(hex_of(d).substr(0, c.mac_hex.size()), c.mac_hex) << "RFC 4231 test case " << i + 1;
    // The same object, reused (the precomputed states are not consumed).
    EXPECT_EQ(hmac.mac(bytes_of(c.data)), d) << "test case " << i + 1 << ", second use";
    EXPECT_TRUE(hmac.verify(bytes_of(c.data), std::span(d).first(16)));
  }
}

TEST(HmacSha256Test, VerifyRefusesEveryFlippedBitOfMessageOrTagAndAnotherKey) {
  const std::string key = "0123456789abcdef0123456789abcdef";
  const HmacSha256 hmac(bytes_of(key));
  std::string message = "a STATE datagram, say: positions, forces, the nonces and the sequence";
  const Sha256::Digest full = hmac.mac(bytes_of(message));
  std::array<std::byte, 16> tag;
  std::copy_n(full.begin(), tag.size(), tag.begin());
  ASSERT_TRUE(hmac.verify(bytes_of(message), tag));
  for (std::size_t i = 0; i < message.size(); ++i)
    for (int bit = 0; bit < 8; ++bit) {
      std::string m = message;
      m[i] = static_cast<char>(m[i] ^ (1 << bit));
      ASSERT_FALSE(hmac.verify(bytes_of(m), tag)) << "message byte " << i << " bit " << bit;
    }
  for (std::size_t i = 0; i < tag.size(); ++i)
    for (int bit = 0; bit < 8; ++bit) {
      auto t = tag;
      t[i] ^= std::byte(1u << bit);
      ASSERT_FALSE(hmac.verify(bytes_of(message), t)) << "tag byte " << i << " bit " << bit;
    }
  EXPECT_FALSE(HmacSha256(bytes_of("0123456789abcdef0123456789abcdeF")).verify(bytes_of(message), tag));
  EXPECT_FALSE(HmacSha256().verify(bytes_of(message), tag));  // the empty key
  EXPECT_FALSE(hmac.verify(bytes_of(message), {}));             // no tag is not a match
}

}  // namespace
}  // namespace hapticlab
