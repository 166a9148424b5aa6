// ARIS live protocol, discovery: the Availability beacon's codec.
#include "vog/sonar/aris_availability.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace vog::sonar {
namespace {

using Bytes = std::vector<std::uint8_t>;

ArisAvailability sample() {
  return {.serial_number = 1234,
          .system_type = ArisSystemType::k3000,
          .version_major = 2,
          .version_minor = 8,
          .version_build = 8403,
          .busy = true,
          .capabilities = {"rotator", "telephoto"}};
}

TEST(ArisAvailability, RoundTripsEveryField) {
  for (const ArisSystemType type : {ArisSystemType::k1800, ArisSystemType::k3000, ArisSystemType::k1200}) {
    for (const bool busy : {false, true}) {
      ArisAvailability a = sample();
      a.system_type = type;
      a.busy = busy;
      auto decoded = decodeArisAvailability(encodeArisAvailability(a));
      ASSERT_TRUE(decoded.ok()) << decoded.error().message;
      EXPECT_EQ(*decoded, a);
    }
  }
  ArisAvailability empty;
  auto decoded = decodeArisAvailability(encodeArisAvailability(empty));
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(*decoded, empty);
}

TEST(ArisAvailability, WireBytesAreTheProtocolFieldNumbers) {
  // serialNumber=1 (1234), systemType=2 (ARIS_1200), softwareVersion=3 {major=1 (2)}, connectionState=4 (BUSY).
  const Bytes wire = {0x08, 0xD2, 0x09, 0x10, 0x02, 0x1A, 0x02, 0x08, 0x02, 0x20, 0x01};
  auto decoded = decodeArisAvailability(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  EXPECT_EQ(decoded->serial_number, 1234u);
  EXPECT_EQ(decoded->system_type, ArisSystemType::k1200);
  EXPECT_EQ(decoded->version_major, 2u);
  EXPECT_TRUE(decoded->busy);
  EXPECT_TRUE(decoded->capabilities.empty());
}

TEST(ArisAvailability, GarbageIsRefusedWithTheReason) {
  for (const Bytes& garbage :
       {Bytes{0xFF, 0xFF, 0xFF}, Bytes{0x0A, 0x05, 0x01}, Bytes{0x1A, 0x10, 0x08}, Bytes{0x00}}) {
    auto decoded = decodeArisAvailability(garbage);
    ASSERT_FALSE(decoded.ok());
    EXPECT_NE(decoded.error().message.find("do not decode"), std::string::npos) << decoded.error().message;
  }
}

TEST(ArisAvailability, UnknownSystemTypeIsRefusedNamingTheValue) {
  Bytes wire = encodeArisAvailability(sample());
  wire.insert(wire.end(), {0x10, 0x07});  // systemType = 7 (the last value of a field wins)
  auto decoded = decodeArisAvailability(wire);
  ASSERT_FALSE(decoded.ok());
  EXPECT_NE(decoded.error().message.find("systemType 7"), std::string::npos) << decoded.error().message;

  wire = encodeArisAvailability(sample());
  wire.insert(wire.end(), {0x20, 0x05});  // connectionState = 5
  decoded = decodeArisAvailability(wire);
  ASSERT_FALSE(decoded.ok());
  EXPECT_NE(decoded.error().message.find("connectionState 5"), std::string::npos) << decoded.error().message;
}

TEST(ArisAvailability, UnknownFieldsAreIgnored) {
  Bytes wire = encodeArisAvailability(sample());
  // cpuTemp = 8 (float 41.5), field 13 (varint 3), field 6 (a length-delimited blob): a real
  // sonar's beacon carries fields the project does not declare.
  wire.insert(wire.end(), {0x45, 0x00, 0x00, 0x26, 0x42, 0x68, 0x03, 0x32, 0x02, 0x08, 0x01});
  auto decoded = decodeArisAvailability(wire);
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  EXPECT_EQ(*decoded, sample());
}

}  // namespace
}  // namespace vog::sonar
