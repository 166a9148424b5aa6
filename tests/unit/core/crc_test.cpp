// The CRCs of the device protocols and of the record files against the CRC catalogue's check values.
#include "vog/core/bytes.hpp"
#include "vog/core/crc.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace vog {
namespace {

TEST(Crc, CheckValuesOfTheStandardCatalogue) {
  // "123456789" check values from the CRC catalogue (reveng.sourceforge.io/crc-catalogue).
  EXPECT_EQ(crc16CcittFalse(asBytes("123456789")), 0x29B1);
  EXPECT_EQ(crc32Ieee(asBytes("123456789")), 0xCBF43926u);
  // NovAtel's CRC has init 0 and no final xor, so a message followed by its own CRC (little-endian)
  // has CRC 0, which is how receivers check it.
  std::vector<std::uint8_t> msg = {0xAA, 0x44, 0x13, 0x28, 0x45, 0x01, 0x07, 0x08};
  const std::uint32_t crc = crc32Novatel(msg);
  EXPECT_NE(crc, 0u);
  ByteWriter(msg).u32(crc);
  EXPECT_EQ(crc32Novatel(msg), 0u);
}

TEST(Crc32c, MatchesTheStandardCheckValueAndExtends) {
  const std::string s = "123456789";
  const std::span<const std::uint8_t> b(reinterpret_cast<const std::uint8_t*>(s.data()), s.size());
  EXPECT_EQ(crc32c(b), 0xE3069283U);  // RFC 3720 B.4 / the CRC catalogue's check value
  EXPECT_EQ(crc32cExtend(crc32c(b.first(4)), b.subspan(4)), 0xE3069283U);
  EXPECT_EQ(crc32c({}), 0U);
}

}  // namespace
}  // namespace vog
