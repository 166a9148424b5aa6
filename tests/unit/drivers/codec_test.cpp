#include "vog/codec/bytes.hpp"
#include "vog/codec/stream_decoder.hpp"

#include <gtest/gtest.h>

namespace vog::codec {
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

// A toy codec: frames are "<" + digits + ">", garbage is anything before '<', "<x" is malformed.
struct AngleCodec {
  using Frame = int;
  DecodeResult<int> decode(std::span<const std::uint8_t> b) const {
    if (b.empty()) return DecodeResult<int>::needMore();
    if (b[0] != '<') {
      std::size_t i = 1;
      while (i < b.size() && b[i] != '<') ++i;
      return DecodeResult<int>::bad(BadKind::kNoSync, i, "garbage");
    }
    int value = 0;
    for (std::size_t i = 1; i < b.size(); ++i) {
      if (b[i] == '>') return DecodeResult<int>::decoded(value, i + 1);
      if (b[i] == '!') return DecodeResult<int>::bad(BadKind::kChecksum, i + 1, "damaged");
      if (b[i] < '0' || b[i] > '9') return DecodeResult<int>::bad(BadKind::kMalformed, 1, "not a digit");
      value = value * 10 + (b[i] - '0');
    }
    return DecodeResult<int>::needMore();
  }
};

TEST(StreamDecoder, DeliversFramesSplitAcrossFeedsAndCountsDrops) {
  StreamDecoder<AngleCodec> d;
  std::vector<int> got;
  for (const char* chunk : {"xx<1", "2><3", "4!>", "<x<5>yy<", "6"}) {
    d.feed(asBytes(chunk));
    while (auto f = d.next()) got.push_back(*f);
  }
  EXPECT_EQ(got, (std::vector<int>{12, 5}));
  EXPECT_EQ(d.stats().frames, 2u);
  EXPECT_EQ(d.stats().bad_checksum, 1u);
  EXPECT_EQ(d.stats().malformed, 1u);
  EXPECT_EQ(d.stats().garbage_bytes, 6u);  // "xx", ">" after "<34!", "x" after the malformed "<", "yy"
  EXPECT_EQ(d.pendingBytes(), 2u);                   // "<6" waits for its '>'
}

TEST(StreamDecoder, BufferLimitDropsOldestBytes) {
  StreamDecoder<AngleCodec> d(AngleCodec{}, 8);
  d.feed(asBytes("<123456789"));  // a frame that never ends: the oldest 2 bytes go
  EXPECT_EQ(d.stats().overflow_bytes, 2u);
  EXPECT_EQ(d.pendingBytes(), 8u);
  EXPECT_FALSE(d.next().has_value());  // "23456789" has no '<': garbage
  EXPECT_EQ(d.stats().garbage_bytes, 8u);
  d.feed(asBytes("<7>"));
  EXPECT_EQ(d.next(), 7);
}

TEST(DecodeResult, BadAlwaysMakesProgress) {
  const auto r = DecodeResult<int>::bad(BadKind::kNoSync, 0, "x");
  EXPECT_EQ(r.consumed(), 1u);
}

}  // namespace
}  // namespace vog::codec
