#include "vog/core/bytes.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/dvl/pd6.hpp"

#include <gtest/gtest.h>

namespace vog::dvl {
namespace {

TEST(Pd6, DecodesManualStyleLines) {
  const std::string lines =
      ":SA,-01.25,+02.50,123.45\r\n"
      ":TS,13052218125392,35.0,+12.3,0010.5,1498.7,000\r\n"
      ":BI,+00123,-00456,+00007,-00002,A\r\n"
      ":BE,-32768,+00010,+00000,V\r\n"
      ":BD,+00000012.34,-00000001.00,+00000000.50,0012.30,000.20\r\n";
  const auto d = codec::decodeAll<Pd6Codec>(asBytes(lines));
  ASSERT_EQ(d.frames.size(), 5u) << d.stats.last_error;
  const auto& sa = std::get<Pd6Attitude>(d.frames[0]);
  EXPECT_DOUBLE_EQ(sa.pitch_deg, -1.25);
  EXPECT_DOUBLE_EQ(sa.heading_deg, 123.45);
  const auto& ts = std::get<Pd6TimeAndScaling>(d.frames[1]);
  EXPECT_EQ(ts.clock.year, 2013);
  EXPECT_EQ(ts.clock.second, 53);
  EXPECT_EQ(ts.clock.hundredths, 92);
  EXPECT_DOUBLE_EQ(ts.sound_speed_mps, 1498.7);
  const auto& bi = std::get<Pd6Velocity>(d.frames[2]);
  EXPECT_EQ(bi.frame, CoordinateFrame::kInstrument);
  EXPECT_TRUE(bi.valid);
  EXPECT_DOUBLE_EQ(bi.velocity_mps[1], -0.456);
  EXPECT_DOUBLE_EQ(bi.error_velocity_mps, -0.002);
  const auto& be = std::get<Pd6Velocity>(d.frames[3]);
  EXPECT_EQ(be.frame, CoordinateFrame::kEarth);
  EXPECT_FALSE(be.valid);
  EXPECT_FALSE(be.component_valid[0]);  // -32768
  EXPECT_FALSE(bottomVelocity(be, 0).ok());
  const auto v = bottomVelocity(bi, 5);
  ASSERT_TRUE(v.ok());
  EXPECT_DOUBLE_EQ(v->velocity_mps[0], 0.123);  // PD6 is already the vehicle's motion
  EXPECT_DOUBLE_EQ(std::get<Pd6Distance>(d.frames[4]).east_m, 12.34);
}

TEST(Pd6, RoundTripEverySentence) {
  Pd6TimeAndScaling ts;
  ts.clock = DvlClock{2026, 11, 21, 23, 5, 9, 99};
  ts.salinity_ppt = 35.0;
  ts.temperature_c = -1.5;
  ts.transducer_depth_m = 101.5;
  ts.sound_speed_mps = 1450.2;
  Pd6Velocity bs;
  bs.frame = CoordinateFrame::kShip;
  bs.velocity_mps = {0.5, -1.25, 0.002};
  bs.component_valid = {true, true, true};
  bs.valid = true;
  Pd6Velocity wi;
  wi.bottom = false;
  wi.velocity_mps = {1.0, 2.0, 3.0};
  wi.component_valid = {true, false, true};
  wi.has_error_velocity = true;
  wi.error_velocity_mps = 0.01;
  const std::vector<Pd6Sentence> in = {Pd6Attitude{-10.5, 3.25, 359.99}, ts, bs, wi,
                                       Pd6Distance{false, -1234.56, 0.01, -3.5, 45.6, 1.25}};
  std::string stream;
  for (const auto& s : in) stream += encodePd6(s);
  const auto d = codec::decodeAll<Pd6Codec>(asBytes(stream));
  ASSERT_EQ(d.frames.size(), in.size()) << d.stats.last_error;
  EXPECT_DOUBLE_EQ(std::get<Pd6Attitude>(d.frames[0]).heading_deg, 359.99);
  EXPECT_EQ(std::get<Pd6TimeAndScaling>(d.frames[1]).clock.hundredths, 99);
  EXPECT_DOUBLE_EQ(std::get<Pd6TimeAndScaling>(d.frames[1]).temperature_c, -1.5);
  EXPECT_DOUBLE_EQ(std::get<Pd6Velocity>(d.frames[2]).velocity_mps[1], -1.25);
  EXPECT_EQ(std::get<Pd6Velocity>(d.frames[2]).frame, CoordinateFrame::kShip);
  const auto& w = std::get<Pd6Velocity>(d.frames[3]);
  EXPECT_FALSE(w.bottom);
  EXPECT_FALSE(w.component_valid[1]);
  EXPECT_DOUBLE_EQ(w.velocity_mps[2], 3.0);
  EXPECT_DOUBLE_EQ(std::get<Pd6Distance>(d.frames[4]).east_m, -1234.56);
  for (const auto& s : in) EXPECT_EQ(encodePd6(s), encodePd6(Pd6Codec{}.decode(asBytes(encodePd6(s))).frame()));
}

TEST(Pd6, GarbageTruncationAndBadLines) {
  const std::string good = encodePd6(Pd6Attitude{1, 2, 3});
  const std::string stream = "xx" + good + ":BI,+00123,-004" + good + ":ZZ,1,2\r\n" + ":SA,1,2\r\n" + good;
  const auto d = codec::decodeAll<Pd6Codec>(asBytes(stream));
  EXPECT_EQ(d.frames.size(), 3u);
  EXPECT_EQ(d.stats.garbage_bytes, 2u);
  EXPECT_EQ(d.stats.malformed, 3u);  // truncated BI, unknown ZZ, SA with 2 fields
  EXPECT_TRUE(Pd6Codec{}.decode(asBytes(":SA,1.0")).isNeedMore());
  EXPECT_TRUE(Pd6Codec{}.decode(asBytes(":" + std::string(200, '1'))).isBad());
}

}  // namespace
}  // namespace vog::dvl
