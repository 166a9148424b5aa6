#include "vog/codec/stream_decoder.hpp"
#include "vog/dvl/pd0.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <random>

namespace vog::dvl {
namespace {

std::vector<std::uint8_t> readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

DvlEnsemble decodeOne(const std::vector<std::uint8_t>& bytes) {
  auto r = Pd0Codec{}.decode(bytes);
  EXPECT_TRUE(r.isFrame()) << r.reason();
  EXPECT_EQ(r.consumed(), bytes.size());
  return std::move(r).frame();
}

// Expected values read by hand from `xxd ../shared/data/pd0/workhorse_1.pd0`:
//   header 7f7f f002 00 06, offsets 0012 004d 008e 0180 01fa 0274 (752-byte ensemble)
//   fixed leader @18: beams 04, cells 1e, pings 000a, cell 0320 cm, blank 0000, EX 1f, bin1 0371 cm,
//                     serial 000048a1, beam angle 14
//   variable leader @77: ensemble 0001, RTC 0d 05 16 12 0c 35 5c (13-05-22 18:12:53.92), MSB 00,
//                        sound speed 0600, depth 0009 dm, heading 14a7, pitch eec5, roll ee93,
//                        salinity 0028, temperature 0924, pressure 00000228 daPa,
//                        Y2K clock 14 0d 05 16 12 0c 35 5c
TEST(Pd0, RealSampleOneMatchesHandReading) {
  const auto bytes = readBytes(test::sharedDataDir() / "pd0" / "workhorse_1.pd0");
  ASSERT_EQ(bytes.size(), 754u);
  const DvlEnsemble e = decodeOne(bytes);
  EXPECT_EQ(e.variable.ensemble_number, 1u);
  EXPECT_EQ(e.variable.clock.year, 2013);
  EXPECT_EQ(e.variable.clock.month, 5);
  EXPECT_EQ(e.variable.clock.day, 22);
  EXPECT_EQ(e.variable.clock.hour, 18);
  EXPECT_EQ(e.variable.clock.minute, 12);
  EXPECT_EQ(e.variable.clock.second, 53);
  EXPECT_EQ(e.variable.clock.hundredths, 92);
  EXPECT_DOUBLE_EQ(e.variable.heading_deg, 52.87);       // 0x14a7 = 5287
  EXPECT_DOUBLE_EQ(e.variable.pitch_deg, -44.11);        // 0xeec5 = -4411
  EXPECT_DOUBLE_EQ(e.variable.roll_deg, -44.61);         // 0xee93 = -4461
  EXPECT_DOUBLE_EQ(e.variable.sound_speed_mps, 1536.0);  // 0x0600
  EXPECT_DOUBLE_EQ(e.variable.temperature_c, 23.40);     // 0x0924 = 2340
  EXPECT_DOUBLE_EQ(e.variable.salinity_ppt, 40.0);
  EXPECT_DOUBLE_EQ(e.variable.transducer_depth_m, 0.9);
  ASSERT_TRUE(e.variable.pressure_pa.has_value());
  EXPECT_DOUBLE_EQ(*e.variable.pressure_pa, 5520.0);  // 0x228 daPa
  EXPECT_EQ(e.fixed.coordinate_transform, 0x1f);
  EXPECT_EQ(e.fixed.coordinate_frame, CoordinateFrame::kEarth);  // 0x1f & 0x18 = 0x18
  EXPECT_TRUE(e.fixed.tilts_used);
  EXPECT_EQ(e.fixed.n_beams, 4);
  EXPECT_EQ(e.fixed.n_cells, 30);
  EXPECT_EQ(e.fixed.pings_per_ensemble, 10);
  EXPECT_DOUBLE_EQ(e.fixed.cell_length_m, 8.0);
  EXPECT_DOUBLE_EQ(e.fixed.bin1_distance_m, 8.81);
  EXPECT_EQ(e.fixed.serial_number, 0x48a1u);
  EXPECT_EQ(e.fixed.beam_angle_deg, 20);
  EXPECT_EQ(e.data_type_ids, (std::vector<std::uint16_t>{0x0000, 0x0080, 0x0100, 0x0200, 0x0300, 0x0400}));
  EXPECT_EQ(e.cell_velocity_mps.size(), 30u);
  EXPECT_FALSE(e.bottom_track.has_value());
  const auto t = clockToUnixNs(e.variable.clock);
  ASSERT_TRUE(t.ok());
  EXPECT_EQ(*t, 1369246373920000000LL);  // date -u -d '2013-05-22 18:12:53.92' +%s%N
}

// workhorse_2.pd0: ensemble 0002, RTC 13-05-22 18:14:53.92, depth 0011 dm, heading 1498, pitch eec5,
// roll ee93, temperature 0923, pressure 000006fc daPa.
TEST(Pd0, RealSampleTwoMatchesHandReading) {
  const DvlEnsemble e = decodeOne(readBytes(test::sharedDataDir() / "pd0" / "workhorse_2.pd0"));
  EXPECT_EQ(e.variable.ensemble_number, 2u);
  EXPECT_EQ(e.variable.clock.minute, 14);
  EXPECT_EQ(e.variable.clock.second, 53);
  EXPECT_DOUBLE_EQ(e.variable.heading_deg, 52.72);
  EXPECT_DOUBLE_EQ(e.variable.pitch_deg, -44.11);
  EXPECT_DOUBLE_EQ(e.variable.roll_deg, -44.61);
  EXPECT_DOUBLE_EQ(e.variable.sound_speed_mps, 1536.0);
  EXPECT_DOUBLE_EQ(e.variable.temperature_c, 23.39);
  EXPECT_DOUBLE_EQ(e.variable.transducer_depth_m, 1.7);
  EXPECT_DOUBLE_EQ(*e.variable.pressure_pa, 17880.0);
  EXPECT_EQ(e.fixed.coordinate_frame, CoordinateFrame::kEarth);
}

DvlEnsemble makeEnsemble(std::uint32_t number) {
  DvlEnsemble e;
  e.fixed.n_beams = 4;
  e.fixed.pings_per_ensemble = 1;
  e.fixed.cell_length_m = 0.5;
  e.fixed.blank_m = 0.25;
  e.fixed.coordinate_frame = CoordinateFrame::kInstrument;
  e.fixed.tilts_used = true;
  e.fixed.bin1_distance_m = 1.03;
  e.fixed.serial_number = 1234;
  e.fixed.beam_angle_deg = 30;
  e.variable.ensemble_number = number;
  e.variable.clock = DvlClock{2026, 11, 21, 23, 59, 58, 7};
  e.variable.sound_speed_mps = 1498;
  e.variable.transducer_depth_m = 12.3;
  e.variable.heading_deg = 359.99;
  e.variable.pitch_deg = -3.25;
  e.variable.roll_deg = 1.5;
  e.variable.salinity_ppt = 35;
  e.variable.temperature_c = -1.25;
  e.variable.pressure_pa = 123450.0;
  e.cell_velocity_mps = {{0.1, -0.2, 0.3, 0.0}, {0.0, 0.0, 0.0, 0.0}};
  e.cell_velocity_valid = {{true, true, true, true}, {false, true, false, true}};
  DvlBottomTrack bt;
  bt.pings_per_ensemble = 1;
  bt.range_m = {12.34, 700.01, 12.5, 12.0};  // 700 m needs the range MSB byte
  bt.velocity_mps = {-0.512, 0.033, 0.001, 0.0};
  bt.velocity_valid = {true, true, true, false};
  bt.correlation = {200, 201, 202, 203};
  bt.amplitude = {50, 51, 52, 53};
  bt.percent_good = {100, 100, 100, 0};
  e.bottom_track = bt;
  return e;
}

TEST(Pd0, EncodeDecodeRoundTrip) {
  const DvlEnsemble in = makeEnsemble(70000);  // > 65535 uses the MSB byte
  const auto bytes = encodePd0(in);
  const DvlEnsemble out = decodeOne(bytes);
  EXPECT_EQ(out.variable.ensemble_number, 70000u);
  EXPECT_EQ(out.variable.clock.year, 2026);
  EXPECT_EQ(out.variable.clock.hundredths, 7);
  EXPECT_DOUBLE_EQ(out.variable.heading_deg, 359.99);
  EXPECT_DOUBLE_EQ(out.variable.pitch_deg, -3.25);
  EXPECT_DOUBLE_EQ(out.variable.temperature_c, -1.25);
  EXPECT_DOUBLE_EQ(out.variable.transducer_depth_m, 12.3);
  EXPECT_DOUBLE_EQ(*out.variable.pressure_pa, 123450.0);
  EXPECT_EQ(out.fixed.coordinate_frame, CoordinateFrame::kInstrument);
  EXPECT_EQ(out.fixed.beam_angle_deg, 30);
  EXPECT_DOUBLE_EQ(out.fixed.bin1_distance_m, 1.03);
  ASSERT_EQ(out.cell_velocity_mps.size(), 2u);
  EXPECT_DOUBLE_EQ(out.cell_velocity_mps[0][1], -0.2);
  EXPECT_EQ(out.cell_velocity_valid[1], (std::array<bool, 4>{false, true, false, true}));
  ASSERT_TRUE(out.bottom_track.has_value());
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(out.bottom_track->range_m[i], in.bottom_track->range_m[i], 0.005);
    EXPECT_EQ(out.bottom_track->velocity_valid[i], in.bottom_track->velocity_valid[i]);
    if (in.bottom_track->velocity_valid[i]) {
      EXPECT_NEAR(out.bottom_track->velocity_mps[i], in.bottom_track->velocity_mps[i], 0.0005);
    }
  }
  EXPECT_EQ(out.bottom_track->correlation, in.bottom_track->correlation);
  // Re-encoding the decoded ensemble gives the same bytes.
  EXPECT_EQ(encodePd0(out), bytes);
}

TEST(Pd0, BottomVelocityIsVehicleMotionAndRejectsBadBeams) {
  DvlEnsemble e = makeEnsemble(1);
  auto v = bottomVelocity(e);
  ASSERT_TRUE(v.ok()) << v.error().message;
  EXPECT_EQ(v->frame, CoordinateFrame::kInstrument);
  EXPECT_DOUBLE_EQ(v->velocity_mps[0], 0.512);  // bottom moves -x: vehicle moves +x
  EXPECT_DOUBLE_EQ(v->velocity_mps[1], -0.033);

  e.fixed.coordinate_frame = CoordinateFrame::kBeam;
  auto beam = bottomVelocity(e);  // beam 4 bad: no 4-beam solution
  ASSERT_FALSE(beam.ok());
  EXPECT_NE(beam.error().message.find("beam 4"), std::string::npos);

  // Pure forward motion u seen by a 30 deg Janus head: beam 1 sees -u sin30, beam 2 +u sin30.
  const double u = 1.0;
  const double s = std::sin(30.0 * 3.14159265358979323846 / 180.0);
  e.bottom_track->velocity_mps = {u * s, -u * s, 0.0, 0.0};  // bottom motion (opposite to vehicle)
  e.bottom_track->velocity_valid = {true, true, true, true};
  auto fwd = bottomVelocity(e);
  ASSERT_TRUE(fwd.ok());
  EXPECT_NEAR(fwd->velocity_mps[0], -u, 1e-12);  // a * (b1 - b2) = u, negated to vehicle motion
  EXPECT_NEAR(fwd->velocity_mps[1], 0.0, 1e-12);
  EXPECT_NEAR(fwd->error_velocity_mps, 0.0, 1e-12);
}

TEST(Pd0, TruncatedEnsembleNeedsMore) {
  const auto bytes = encodePd0(makeEnsemble(3));
  for (std::size_t n : {std::size_t{1}, std::size_t{2}, std::size_t{5}, std::size_t{12}, bytes.size() - 1}) {
    auto r = Pd0Codec{}.decode(std::span(bytes).first(n));
    EXPECT_TRUE(r.isNeedMore()) << "prefix " << n << ": " << r.reason();
  }
}

TEST(Pd0, OversizedLengthRejectedWithoutWaiting) {
  auto bytes = encodePd0(makeEnsemble(3));
  bytes[2] = 0xFF;
  bytes[3] = 0xFF;  // 65535-byte ensemble
  auto r = Pd0Codec{}.decode(std::span(bytes).first(20));
  ASSERT_TRUE(r.isBad());
  EXPECT_EQ(r.badKind(), codec::BadKind::kMalformed);
  EXPECT_NE(r.reason().find("65535"), std::string::npos);
}

TEST(Pd0, StreamResyncsAfterGarbageAndCountsEveryBadChecksum) {
  std::mt19937 rng(42);
  std::vector<std::uint8_t> stream;
  std::vector<std::uint32_t> good_numbers;
  int bad_injected = 0;
  for (std::uint32_t n = 1; n <= 40; ++n) {
    // Random garbage between ensembles, without 7F bytes (a 7F 7F in garbage is a legitimate sync).
    const int garbage = static_cast<int>(rng() % 30);
    for (int i = 0; i < garbage; ++i) stream.push_back(static_cast<std::uint8_t>(rng() % 0x7F));
    auto bytes = encodePd0(makeEnsemble(n));
    if (n % 7 == 0) {
      bytes[100] ^= 0x01;  // damaged in transit: checksum no longer matches
      ++bad_injected;
    } else {
      good_numbers.push_back(n);
    }
    stream.insert(stream.end(), bytes.begin(), bytes.end());
  }
  // Feed in awkward chunk sizes to exercise the incremental path.
  codec::StreamDecoder<Pd0Codec> decoder;
  std::vector<std::uint32_t> got;
  std::size_t pos = 0;
  while (pos < stream.size()) {
    const std::size_t n = std::min<std::size_t>(1 + rng() % 97, stream.size() - pos);
    decoder.feed(std::span(stream).subspan(pos, n));
    pos += n;
    while (auto e = decoder.next()) got.push_back(e->variable.ensemble_number);
  }
  EXPECT_EQ(got, good_numbers);
  EXPECT_EQ(decoder.stats().bad_checksum, static_cast<std::uint64_t>(bad_injected));
  EXPECT_GT(decoder.stats().garbage_bytes, 0u);
  EXPECT_EQ(decoder.pendingBytes(), 0u);
}

TEST(Pd0, TruncatedEnsembleFollowedByGoodOneIsDroppedAndCounted) {
  const auto a = encodePd0(makeEnsemble(1));
  const auto b = encodePd0(makeEnsemble(2));
  std::vector<std::uint8_t> stream(a.begin(), a.begin() + 120);  // device reset mid-ensemble
  stream.insert(stream.end(), b.begin(), b.end());
  stream.insert(stream.end(), a.begin(), a.end());
  const auto decoded = codec::decodeAll<Pd0Codec>(stream);
  ASSERT_EQ(decoded.frames.size(), 2u);
  EXPECT_EQ(decoded.frames[0].variable.ensemble_number, 2u);
  EXPECT_EQ(decoded.frames[1].variable.ensemble_number, 1u);
  EXPECT_EQ(decoded.stats.bad_checksum, 1u);
}

}  // namespace
}  // namespace vog::dvl
