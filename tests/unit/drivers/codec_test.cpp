#include "vog/codec/stream_decoder.hpp"
#include "vog/core/bytes.hpp"

#include <gtest/gtest.h>

namespace vog::codec {
namespace {

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
  EXPECT_EQ(d.pendingBytes(), 2u);         // "<6" waits for its '>'
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
