#include "vog/core/bytes.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/depth/digiquartz.hpp"
#include "vog/depth/unesco.hpp"

#include <gtest/gtest.h>

namespace vog::depth {
namespace {

TEST(Unesco, CheckValueOfTheTechnicalPaper) {
  // Fofonoff & Millard (1983) p. 28: P = 10000 dbar, latitude 30 deg -> 9712.653 m.
  EXPECT_NEAR(unescoDepth_m(10000.0, 30.0), 9712.653, 0.0005);
  EXPECT_DOUBLE_EQ(unescoDepth_m(0.0, 30.0), 0.0);
  // Gravity grows toward the poles, so the same pressure is a shallower depth there.
  EXPECT_LT(unescoDepth_m(1000.0, 80.0), unescoDepth_m(1000.0, 0.0));
}

TEST(Digiquartz, DecodesPolledAndContinuousReplies) {
  const std::string stream = "*000114.6963\r\n*000114.6970\r\n*0001UN=1\r\n";
  const auto d = codec::decodeAll<DigiquartzCodec>(asBytes(stream));
  ASSERT_EQ(d.frames.size(), 3u);
  EXPECT_EQ(d.frames[0].kind, DigiquartzMessage::Kind::kPressure);
  EXPECT_EQ(d.frames[0].destination, 0);
  EXPECT_EQ(d.frames[0].source, 1);
  EXPECT_DOUBLE_EQ(d.frames[0].value, 14.6963);
  EXPECT_DOUBLE_EQ(d.frames[1].value, 14.6970);
  EXPECT_EQ(d.frames[2].kind, DigiquartzMessage::Kind::kParameter);
  EXPECT_DOUBLE_EQ(d.frames[2].value, 1.0);
}

TEST(Digiquartz, DecodesHostCommandsIncludingWriteEnable) {
  const auto d = codec::decodeAll<DigiquartzCodec>(asBytes("*0100P3\r\n*0100P4\r\n*0100EW*0100UN=2\r\n"));
  ASSERT_EQ(d.frames.size(), 3u);
  EXPECT_EQ(d.frames[0].kind, DigiquartzMessage::Kind::kCommand);
  EXPECT_EQ(d.frames[0].destination, 1);
  EXPECT_EQ(d.frames[0].body, "P3");
  EXPECT_EQ(d.frames[1].body, "P4");
  EXPECT_TRUE(d.frames[2].write_enabled);
  EXPECT_EQ(d.frames[2].body, "UN=2");
  EXPECT_DOUBLE_EQ(d.frames[2].value, 2.0);
}

TEST(Digiquartz, RoundTripAndResyncAfterGarbage) {
  std::string stream = "\x13\xff garbage";
  stream += encodePressureReply(0, 1, 101.325, 4);
  stream += "*00011x.2\r\n";  // damaged reply: malformed, dropped
  stream += encodeCommand(1, 0, "P3");
  stream += "*0001";  // a reply cut off by a reset, then a full one
  stream += encodePressureReply(0, 1, -0.0012, 4);
  const auto d = codec::decodeAll<DigiquartzCodec>(asBytes(stream));
  ASSERT_EQ(d.frames.size(), 3u);
  EXPECT_DOUBLE_EQ(d.frames[0].value, 101.325);
  EXPECT_EQ(d.frames[1].body, "P3");
  EXPECT_DOUBLE_EQ(d.frames[2].value, -0.0012);
  EXPECT_EQ(d.stats.malformed, 2u);
  EXPECT_EQ(d.stats.garbage_bytes, 10u);
}

TEST(Digiquartz, TruncatedLineNeedsMoreAndOverlongLineIsRejected) {
  EXPECT_TRUE(DigiquartzCodec{}.decode(asBytes("*000114.69")).isNeedMore());
  const std::string longline = "*0001" + std::string(100, '1');
  const auto r = DigiquartzCodec{}.decode(asBytes(longline));
  ASSERT_TRUE(r.isBad());
  EXPECT_EQ(r.badKind(), codec::BadKind::kMalformed);
}

TEST(Digiquartz, PressureToDepthSubtractsAtmosphere) {
  DepthConversionConfig cfg;
  cfg.units_code = static_cast<int>(PressureUnit::kKpa);
  cfg.latitude_deg = 30.0;
  cfg.atmospheric_pressure_pa = 101325.0;
  DigiquartzMessage m;
  m.value = 101.325 + 100000.0;  // kPa absolute = 10000 dbar sea pressure
  const auto s = toDepthSample(m, cfg, 7);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->stamp_ns, 7);
  EXPECT_NEAR(s->sea_pressure_pa, 1.0e8, 1e-3);
  EXPECT_NEAR(s->depth_m, 9712.653, 0.0005);

  cfg.units_code = 1;  // psi: 14.6959 psi is one standard atmosphere, depth ~ 0
  m.value = 14.6959488;
  EXPECT_NEAR(toDepthSample(m, cfg, 0)->depth_m, 0.0, 1e-4);
}

TEST(Digiquartz, BadConfigAndNonPressureAreErrorsNamingTheProblem) {
  DepthConversionConfig cfg;
  cfg.latitude_deg = 91.0;
  const auto st = cfg.validate();
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("latitude_deg"), std::string::npos);
  EXPECT_NE(st.error().message.find("91"), std::string::npos);
  DigiquartzMessage cmd;
  cmd.kind = DigiquartzMessage::Kind::kCommand;
  cmd.body = "P3";
  EXPECT_FALSE(toDepthSample(cmd, DepthConversionConfig{}, 0).ok());
}

}  // namespace
}  // namespace vog::depth
