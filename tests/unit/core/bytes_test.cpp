// Byte fields: what ByteWriter appends ByteReader reads back, and a read past the end names its field.
#include "vog/core/bytes.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace vog {
namespace {

TEST(Bytes, WriterAndReaderRoundTripLittleEndian) {
  std::vector<std::uint8_t> out;
  ByteWriter w(out);
  w.u8(0x12);
  w.u16(0x3456);
  w.u32(0x789ABCDEU);
  w.i64(-2);
  w.f64(-0.1);
  w.string16("abc");
  EXPECT_EQ(out[1], 0x56);  // little-endian
  EXPECT_EQ(readU32LE(out, 3), 0x789ABCDEU);
  ByteReader r(out);
  EXPECT_EQ(r.u8("a"), 0x12);
  EXPECT_EQ(r.u16("b"), 0x3456);
  EXPECT_EQ(r.u32("c"), 0x789ABCDEU);
  EXPECT_EQ(r.i64("d"), -2);
  EXPECT_EQ(r.f64("e"), -0.1);
  EXPECT_EQ(r.string16("f"), "abc");
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.remaining(), 0U);
}

TEST(Bytes, ReaderNamesTheFieldThatDoesNotFitAndStops) {
  const std::vector<std::uint8_t> in = {1, 2, 3};
  ByteReader r(in);
  EXPECT_EQ(r.u16("first"), 0x0201);
  EXPECT_EQ(r.u32("second"), 0U);
  EXPECT_EQ(r.u8("third"), 0U);  // after the first error every read is zero
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.error(), "payload ends inside field 'second' (4 bytes needed, 1 left)");
}

}  // namespace
}  // namespace vog
