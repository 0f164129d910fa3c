// sha256_hex, the protocol hash of a study: the FIPS 180 example vectors
// through the hex form (the digest itself: hmac_sha256_test.cc).
#include "core/common/sha256.h"

#include <string>

#include <gtest/gtest.h>

namespace hapticlab {
namespace {

// FIPS 180-2 Appendix B / NIST CSRC "SHA256.pdf" example vectors.
TEST(Sha256Hex, FipsOneBlockMessage) {
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(Sha256Hex, FipsTwoBlockMessage) {
  EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

TEST(Sha256Hex, FipsLongMessageOneMillionA) {
  EXPECT_EQ(sha256_hex(std::string(1'000'000, 'a')),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256Hex, EmptyAndBlockBoundaryLengths) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  // 896-bit message of FIPS 180-2 (two blocks with the padding in a third).
  EXPECT_EQ(sha256_hex("abcdefghbcdefghicdefghijdefghijkefghijklfghijklmghijklmnhijklmnoijklmnopjklmnopqklmnopqrlmnop"
                       "qrsmnopqrstnopqrstu"),
            "cf5b16a778af8380036ce59e7b0492370b249b11e8f07a51afac45037afee9d1");
}

}  // namespace
}  // namespace hapticlab
