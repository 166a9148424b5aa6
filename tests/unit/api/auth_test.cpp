#include "vog/api/auth.hpp"

#include <gtest/gtest.h>

namespace vog::api {
namespace {

std::string fromHex(std::string_view hex) {
  std::string out;
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2) {
    out += static_cast<char>(std::stoi(std::string(hex.substr(i, 2)), nullptr, 16));
  }
  return out;
}

// RFC 4231 test cases 1 and 2 (HMAC-SHA-256).
TEST(Auth, HmacSha256MatchesRfc4231) {
  EXPECT_EQ(toHex(asBytes(hmacSha256(std::string(20, '\x0b'), "Hi There"))),
            "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7");
  EXPECT_EQ(toHex(asBytes(hmacSha256("Jefe", "what do ya want for nothing?"))),
            "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
}

TEST(Auth, ClientMacCoversServerNonceClientNonceAndLabelInThatOrder) {
  const std::string secret = "correct horse battery staple";
  const std::string sn(32, '\x01');
  const std::string cn(32, '\x02');
  EXPECT_EQ(toHex(asBytes(clientMac(secret, sn, cn))), toHex(asBytes(hmacSha256(secret, sn + cn + "vog.v1"))));
  EXPECT_EQ(toHex(asBytes(serverProof(secret, sn, cn))), toHex(asBytes(hmacSha256(secret, cn + sn + "vog.v1 server"))));
  // Swapping the nonces, changing the secret or a single bit changes the MAC.
  EXPECT_NE(clientMac(secret, sn, cn), clientMac(secret, cn, sn));
  EXPECT_NE(clientMac(secret, sn, cn), clientMac(secret + "!", sn, cn));
  std::string flipped = cn;
  flipped[31] = static_cast<char>(flipped[31] ^ 0x80);
  EXPECT_NE(clientMac(secret, sn, cn), clientMac(secret, sn, flipped));
  // The client's MAC is not the server's proof (no reflection of one as the other).
  EXPECT_NE(clientMac(secret, sn, cn), serverProof(secret, sn, cn));
}

// The worked example of proto/README.md "Authentication": the same bytes give the same hex.
TEST(Auth, ReadmeWorkedExample) {
  std::string sn;
  std::string cn;
  for (int i = 0; i < 32; ++i) {
    sn += static_cast<char>(i);
    cn += static_cast<char>(0xa0 + i);
  }
  EXPECT_EQ(toHex(asBytes(clientMac("vog-example-secret", sn, cn))),
            "984b3872fb0424dfde83ed632122a4e3d637ff53d6fb991f707167cbd831fdb3");
  EXPECT_EQ(toHex(asBytes(serverProof("vog-example-secret", sn, cn))),
            "f04f36f3539addb8c787547c1856488676499793d2470fe54edb736db557e130");
  // The MAC input spelled out as in the README.
  EXPECT_EQ(toHex(sn + cn + "vog.v1"),
            "000102030405060708090a0b0c0d0e0f101112131415161718191a1b1c1d1e1f"
            "a0a1a2a3a4a5a6a7a8a9aaabacadaeafb0b1b2b3b4b5b6b7b8b9babbbcbdbebf766f672e7631");
  EXPECT_EQ(fromHex("766f672e7631"), "vog.v1");
}

TEST(Auth, MacEqualsComparesWholeValueAndLength) {
  const Mac m = hmacSha256("k", "m");
  EXPECT_TRUE(macEquals(asBytes(m), m));
  std::string wrong(asBytes(m));
  wrong[0] = static_cast<char>(wrong[0] ^ 1);
  EXPECT_FALSE(macEquals(wrong, m));
  wrong = std::string(asBytes(m));
  wrong[31] = static_cast<char>(wrong[31] ^ 1);
  EXPECT_FALSE(macEquals(wrong, m));
  EXPECT_FALSE(macEquals(std::string(asBytes(m)).substr(0, 31), m));
  EXPECT_FALSE(macEquals("", m));
}

TEST(Auth, NonceSources) {
  SeededNonceSource a(42);
  SeededNonceSource b(42);
  SeededNonceSource c(43);
  const std::string na = a.nonce(32).value();
  EXPECT_EQ(na.size(), 32u);
  EXPECT_EQ(na, b.nonce(32).value());
  EXPECT_NE(na, c.nonce(32).value());
  EXPECT_NE(na, a.nonce(32).value());  // a fresh nonce per call
  SystemNonceSource sys;
  const std::string s1 = sys.nonce(32).value();
  const std::string s2 = sys.nonce(32).value();
  EXPECT_EQ(s1.size(), 32u);
  EXPECT_NE(s1, s2);
  EXPECT_EQ(a.nonce(5).value().size(), 5u);
}

}  // namespace
}  // namespace vog::api
