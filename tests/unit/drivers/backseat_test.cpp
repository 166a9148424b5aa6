#include "vog/backseat/backseat.hpp"
#include "vog/backseat/local_tangent_plane.hpp"
#include "vog/core/bytes.hpp"
#include "vog/codec/stream_decoder.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace vog::backseat {
namespace {

TEST(Backseat, ChecksumIsXorBetweenDollarAndStar) {
  // NMEA-style example: XOR of "GPGLL,5300.97914,N,00259.98174,E,125926,A" is 0x28 (NMEA 0183).
  EXPECT_EQ(xorChecksum("GPGLL,5300.97914,N,00259.98174,E,125926,A"), 0x28);
  const std::string s = encodeBackseat(Heartbeat{TimeOfDay{3661.5}, 1, "mapping"});
  EXPECT_EQ(s.substr(0, 23), "$BPSTS,010101.50,1,mapp");
  EXPECT_EQ(s.substr(s.size() - 2), "\r\n");
}

TEST(Backseat, NavigationRoundTrip) {
  NavSentence n;
  n.time = TimeOfDay{45296.25};  // 12:34:56.25
  n.latitude_deg = 42.358123;
  n.longitude_deg = -71.087654;
  n.quality = 1;
  n.altitude_m = 3.25;
  n.depth_m = 12.5;
  n.heading_deg = 271.3;
  n.roll_deg = -1.2;
  n.pitch_deg = 0.5;
  n.computed_time = TimeOfDay{45296.2};
  const std::string wire = encodeBackseat(n);
  EXPECT_EQ(wire.substr(0, 48), "$BFNVG,123456.25,4221.487380,N,07105.259240,W,1,");
  auto r = BackseatCodec{}.decode(asBytes(wire));
  ASSERT_TRUE(r.isFrame()) << r.reason();
  const auto& out = std::get<NavSentence>(r.frame());
  EXPECT_NEAR(out.latitude_deg, n.latitude_deg, 1e-6 / 60.0);
  EXPECT_NEAR(out.longitude_deg, n.longitude_deg, 1e-6 / 60.0);
  EXPECT_DOUBLE_EQ(out.time.seconds_since_midnight, 45296.25);
  EXPECT_DOUBLE_EQ(out.depth_m, 12.5);
  EXPECT_DOUBLE_EQ(out.heading_deg, 271.3);
  EXPECT_DOUBLE_EQ(out.roll_deg, -1.2);
  EXPECT_EQ(out.quality, 1);

  NavRateSentence v{0, TimeOfDay{1.0}, 0.5, -0.25, 0.01, 1.5, -2.5, 3.0};
  auto rv = BackseatCodec{}.decode(asBytes(encodeBackseat(v)));
  ASSERT_TRUE(rv.isFrame()) << rv.reason();
  EXPECT_DOUBLE_EQ(std::get<NavRateSentence>(rv.frame()).north_mps, -0.25);
  EXPECT_DOUBLE_EQ(std::get<NavRateSentence>(rv.frame()).yaw_rate_dps, 3.0);
}

TEST(Backseat, CommandAckAndOtherSentencesRoundTrip) {
  WaypointCommand w{TimeOfDay{10.0}, 42, -33.5, 151.25, 20.0, 0.75, std::nullopt};
  auto rw = BackseatCodec{}.decode(asBytes(encodeBackseat(w)));
  ASSERT_TRUE(rw.isFrame()) << rw.reason();
  const auto& wo = std::get<WaypointCommand>(rw.frame());
  EXPECT_EQ(wo.id, 42u);
  EXPECT_NEAR(wo.latitude_deg, -33.5, 1e-9);
  EXPECT_NEAR(wo.longitude_deg, 151.25, 1e-9);
  EXPECT_DOUBLE_EQ(wo.speed_mps, 0.75);

  AckSentence a{0, TimeOfDay{11.0}, "BPGHP", TimeOfDay{10.0}, 42, AckStatus::kFailed, "depth limit"};
  auto ra = BackseatCodec{}.decode(asBytes(encodeBackseat(a)));
  ASSERT_TRUE(ra.isFrame()) << ra.reason();
  EXPECT_EQ(std::get<AckSentence>(ra.frame()).status, AckStatus::kFailed);
  EXPECT_EQ(std::get<AckSentence>(ra.frame()).reason, "depth limit");

  auto ro = BackseatCodec{}.decode(asBytes(encodeBackseat(BackseatOther{"BFRDP", {"120000.00", "101.3"}})));
  ASSERT_TRUE(ro.isFrame()) << ro.reason();
  EXPECT_EQ(std::get<BackseatOther>(ro.frame()).fields[1], "101.3");
}

TEST(Backseat, StreamCountsBadChecksumsAndResyncs) {
  const std::string good = encodeBackseat(Heartbeat{TimeOfDay{1.0}, 0, "idle"});
  std::string damaged = good;
  damaged[10] = damaged[10] == '1' ? '2' : '1';
  std::string stream = "noise\x01" + good + damaged + "$BFNVG,1200" + good + damaged + good;
  const auto d = codec::decodeAll<BackseatCodec>(asBytes(stream));
  EXPECT_EQ(d.frames.size(), 3u);
  EXPECT_EQ(d.stats.bad_checksum, 2u);
  EXPECT_EQ(d.stats.malformed, 1u);  // the sentence cut short by the next '$'
  EXPECT_EQ(d.stats.garbage_bytes, 6u);
  EXPECT_TRUE(BackseatCodec{}.decode(asBytes("$BFNVG,12")).isNeedMore());
  EXPECT_EQ(BackseatCodec{}.decode(asBytes("$BFNVG,1*00\r\n")).badKind(), codec::BadKind::kChecksum);
  // Right checksum, wrong content: malformed with the field named.
  const std::string body = "BFNVG,99xx,1";
  char cs[8];
  std::snprintf(cs, sizeof cs, "*%02X\r\n", xorChecksum(body));
  const auto bad = BackseatCodec{}.decode(asBytes("$" + body + cs));
  ASSERT_TRUE(bad.isBad());
  EXPECT_EQ(bad.badKind(), codec::BadKind::kMalformed);
  EXPECT_NE(bad.reason().find("fields"), std::string::npos);
}

TEST(AckTracker, ResendsEveryFiveSecondsAndGivesUpAfterThreeTries) {
  AckTracker t;
  constexpr std::int64_t s = 1'000'000'000;
  const WaypointCommand w{TimeOfDay{0.0}, 7, 10.0, 20.0, 5.0, 1.0, std::nullopt};
  auto first = t.send(w, 0);
  ASSERT_TRUE(first.ok());
  EXPECT_FALSE(t.send(w, 1).ok());  // same id already pending
  EXPECT_TRUE(t.poll(4 * s).empty());
  auto r1 = t.poll(5 * s);
  ASSERT_EQ(r1.size(), 1u);
  EXPECT_EQ(r1[0], *first);
  EXPECT_EQ(t.poll(10 * s).size(), 1u);  // third attempt
  EXPECT_TRUE(t.poll(14 * s).empty());
  EXPECT_TRUE(t.poll(15 * s).empty());  // exhausted: no fourth send
  const auto outcomes = t.takeOutcomes();
  ASSERT_EQ(outcomes.size(), 1u);
  EXPECT_FALSE(outcomes[0].accepted);
  EXPECT_NE(outcomes[0].reason.find("3 attempts"), std::string::npos);
  EXPECT_EQ(t.pendingCount(), 0u);
}

TEST(AckTracker, AckSettlesTheCommandAndUnknownAckIsAnError) {
  AckTracker t;
  ASSERT_TRUE(t.send(WaypointCommand{TimeOfDay{}, 1, 0, 0, 1, 1, std::nullopt}, 0).ok());
  ASSERT_TRUE(t.send(WaypointCommand{TimeOfDay{}, 2, 0, 0, 1, 1, std::nullopt}, 0).ok());
  auto o = t.onAck(AckSentence{0, TimeOfDay{}, "BPGHP", TimeOfDay{}, 2, AckStatus::kAccepted, ""});
  ASSERT_TRUE(o.ok());
  EXPECT_TRUE(o->accepted);
  EXPECT_EQ(o->command_id, 2u);
  EXPECT_FALSE(t.onAck(AckSentence{0, TimeOfDay{}, "BPGHP", TimeOfDay{}, 2, AckStatus::kAccepted, ""}).ok());
  EXPECT_EQ(t.poll(5'000'000'000).size(), 1u);  // only command 1 is resent
}

TEST(Heartbeat, DueOncePerSecond) {
  HeartbeatScheduler h;
  EXPECT_TRUE(h.due(0));
  (void)h.emit(Heartbeat{}, 100);
  EXPECT_FALSE(h.due(999'999'999));
  EXPECT_TRUE(h.due(1'000'000'100));
}

TEST(Backseat, GoToPositionCarriesAnOptionalHeadingAndMillimetrePositions) {
  WaypointCommand w;
  w.time = TimeOfDay{100.0};
  w.id = 9;
  w.latitude_deg = 42.000012345;
  w.longitude_deg = -70.999987655;
  w.depth_m = 2.5;
  w.speed_mps = 0.25;
  for (const std::optional<double> heading : {std::optional<double>{}, std::optional<double>{271.25}}) {
    w.heading_deg = heading;
    const std::string text = encodeBackseat(w);
    auto r = BackseatCodec{}.decode(asBytes(text));
    ASSERT_TRUE(r.isFrame()) << text;
    const auto& back = std::get<WaypointCommand>(r.frame());
    // 1e-6 minute of arc: 1.7e-8 deg, about 2 mm.
    EXPECT_NEAR(back.latitude_deg, w.latitude_deg, 2e-8);
    EXPECT_NEAR(back.longitude_deg, w.longitude_deg, 2e-8);
    ASSERT_EQ(back.heading_deg.has_value(), heading.has_value()) << text;
    if (heading) {
      EXPECT_DOUBLE_EQ(*back.heading_deg, *heading);
    }
  }
  // A heading outside [0, 360) is named.
  auto bad = BackseatCodec{}.decode(asBytes(encodeBackseat(
      BackseatOther{"BPGHP", {"000140.00", "9", "4200.000741", "N", "07059.999259", "W", "2.50", "0.25", "360.5"}})));
  ASSERT_TRUE(bad.isBad());
  EXPECT_NE(bad.reason().find("heading"), std::string::npos) << bad.reason();
}

TEST(LocalTangentPlaneTest, DegreeLengthsMatchWgs84TablesAndRoundTrip) {
  auto ltp = LocalTangentPlane::create({42.0, -71.0});
  ASSERT_TRUE(ltp.ok());
  // WGS84 lengths of a degree by the usual series (e.g. the NGA/Wikipedia "length of a degree"
  // expansions), independent of the closed form in the plane: at 42 deg about 111 073 m of
  // latitude and 82 850 m of longitude.
  const double phi = 42.0 * std::numbers::pi / 180.0;
  const double lat_m = 111'132.954 - 559.822 * std::cos(2 * phi) + 1.175 * std::cos(4 * phi);
  const double lon_m = 111'412.84 * std::cos(phi) - 93.5 * std::cos(3 * phi) + 0.118 * std::cos(5 * phi);
  EXPECT_NEAR(ltp->metresPerDegreeLatitude(), lat_m, 1.0);
  EXPECT_NEAR(ltp->metresPerDegreeLongitude(), lon_m, 1.0);
  for (const Eigen::Vector2d& xy :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(-5.25, 3.5), Eigen::Vector2d(812.0, -9000.0)}) {
    const GeoPoint g = ltp->toGeo(xy);
    EXPECT_LT((ltp->toLocal(g) - xy).norm(), 1e-6);
  }
  const GeoPoint north = ltp->toGeo(Eigen::Vector2d(0.0, 1852.0));  // one nautical mile north
  EXPECT_NEAR((north.latitude_deg - 42.0) * 60.0, 1.0, 0.01);       // = one minute of latitude
  EXPECT_FALSE(LocalTangentPlane::create({85.0, 0.0}).ok());
  EXPECT_FALSE(LocalTangentPlane::create({0.0, 181.0}).ok());
  EXPECT_FALSE(LocalTangentPlane::create({std::nan(""), 0.0}).ok());
}

}  // namespace
}  // namespace vog::backseat
