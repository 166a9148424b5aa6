// The simulator-to-wire bridge (sim/vehicle sim_wire.hpp): frame conventions against the
// navigation's own conversion, exact inverses, and bad input named.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vog/core/bytes.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/depth/digiquartz.hpp"
#include "vog/depth/unesco.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/vehicle/sim_wire.hpp"
#include "vog/nav/dead_reckoning.hpp"

namespace vog::vehicle {
namespace {

TEST(SimWireTest, NedAttitudeIsTheInverseOfTheNavigationConversion) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), tilt(-1.2, 1.2);
  for (int i = 0; i < 200; ++i) {
    const double roll = angle(rng), pitch = tilt(rng), heading = angle(rng);
    const Eigen::Vector3d got = nedRollPitchHeading(nav::worldFromNedAttitude(roll, pitch, heading));
    EXPECT_NEAR(got.x(), roll, 1e-9);
    EXPECT_NEAR(got.y(), pitch, 1e-9);
    EXPECT_NEAR(geometry::wrapAngle(got.z() - heading), 0.0, 1e-9);
  }
  // World yaw 0 (facing east) is NED heading 90 deg; a nose-up vehicle has positive NED pitch.
  const Eigen::Vector3d east = nedRollPitchHeading(Eigen::Matrix3d::Identity());
  EXPECT_NEAR(east.z(), M_PI / 2, 1e-12);
  const Eigen::Matrix3d nose_up = geometry::poseFromXyzRpy(0, 0, 0, 0, -0.1, 0).linear();  // FLU pitch about y-left
  EXPECT_NEAR(nedRollPitchHeading(nose_up).y(), 0.1, 1e-12);
}

TEST(SimWireTest, DigiquartzReadingDecodesToTheSimulatedDepth) {
  SimWireConfig c;
  for (const double depth_m : {0.0, 1.5, 4.0, 250.0, 6000.0}) {
    auto reading = toDigiquartzReading(sim::DepthSample{5, depth_m}, c);
    ASSERT_TRUE(reading.ok()) << reading.error().message;
    const std::string line = depth::encodePressureReply(0, 1, *reading, 9);
    codec::StreamDecoder<depth::DigiquartzCodec> dec;
    dec.feed(asBytes(line));
    auto msg = dec.next();
    ASSERT_TRUE(msg.has_value());
    auto sample = depth::toDepthSample(*msg, c.depth, 5);
    ASSERT_TRUE(sample.ok());
    EXPECT_NEAR(sample->depth_m, depth_m, 1e-6) << line;
  }
  // UNESCO 1983 check value (Fofonoff & Millard p. 28): 10000 dbar at 30 deg -> 9712.653 m.
  auto p = seaPressureForDepth_dbar(9712.653, 30.0);
  ASSERT_TRUE(p.ok());
  EXPECT_NEAR(*p, 10000.0, 1e-3);
  EXPECT_FALSE(seaPressureForDepth_dbar(std::nan(""), 42.0).ok());
  EXPECT_FALSE(toDigiquartzReading(sim::DepthSample{0, 20000.0}, c).ok());
}

TEST(SimWireTest, DvlSampleBecomesABottomTrackOfTheBottomsMotionInInstrumentFrame) {
  sim::DvlSample s;
  s.stamp_ns = 1'500'000'000;
  s.bottom_lock = true;
  s.velocity_vehicle_mps = Eigen::Vector3d(0.2, 0.05, -0.01);  // forward, left, up
  s.altitude_m = 2.5;
  auto e = toPd0Ensemble(s, 42, SimWireConfig{});
  ASSERT_TRUE(e.ok()) << e.error().message;
  codec::StreamDecoder<dvl::Pd0Codec> dec;
  dec.feed(dvl::encodePd0(*e));
  auto d = dec.next();
  ASSERT_TRUE(d.has_value()) << dec.stats().last_error;
  ASSERT_TRUE(d->bottom_track.has_value());
  // Instrument x starboard = -left, y forward; PD0 bottom track is the bottom's motion (negated).
  EXPECT_NEAR(d->bottom_track->velocity_mps[0], 0.05, 1e-3);
  EXPECT_NEAR(d->bottom_track->velocity_mps[1], -0.2, 1e-3);
  EXPECT_NEAR(d->bottom_track->velocity_mps[2], 0.01, 1e-3);
  EXPECT_NEAR(d->bottom_track->range_m[0], 2.5, 0.01);
  EXPECT_EQ(d->variable.ensemble_number, 42u);
  EXPECT_EQ(d->fixed.coordinate_frame, dvl::CoordinateFrame::kInstrument);
  // The real-time clock carries the epoch plus the stamp.
  auto t = dvl::clockToUnixNs(d->variable.clock);
  ASSERT_TRUE(t.ok());
  EXPECT_EQ(*t, SimWireConfig{}.epoch_unix_ns + s.stamp_ns);
  // Navigation turns it back into the vehicle's velocity.
  nav::DeadReckoning dr;
  imu::ImuSample level;
  level.stamp_ns = s.stamp_ns;
  level.attitude = imu::ImuAttitude{0.0, 0.0, M_PI / 2};  // facing east: vehicle forward = world x
  ASSERT_TRUE(dr.addImu(level).ok());
  d->stamp_ns = s.stamp_ns;
  ASSERT_TRUE(dr.addDvl(*d).ok());
  EXPECT_NEAR(dr.solution(s.stamp_ns).velocity_world_mps.x(), 0.2, 1e-3);
  EXPECT_NEAR(dr.solution(s.stamp_ns).velocity_world_mps.y(), 0.05, 1e-3);

  // No bottom lock: every velocity is marked bad on the wire and navigation rejects it.
  s.bottom_lock = false;
  auto lost = toPd0Ensemble(s, 43, SimWireConfig{});
  ASSERT_TRUE(lost.ok());
  dec.feed(dvl::encodePd0(*lost));
  auto dl = dec.next();
  ASSERT_TRUE(dl.has_value());
  for (bool valid : dl->bottom_track->velocity_valid) EXPECT_FALSE(valid);
}

TEST(SimWireTest, BadInputIsNamed) {
  SimWireConfig c;
  c.dvl_beam_angle_deg = 0;
  auto e = toPd0Ensemble(sim::DvlSample{}, 1, c);
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.error().message.find("sim_wire.dvl_beam_angle_deg"), std::string::npos) << e.error().message;
  SimWireConfig d;
  d.depth.units_code = 99;
  auto r = toDigiquartzReading(sim::DepthSample{0, 1.0}, d);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("units_code"), std::string::npos) << r.error().message;
  sim::ImuSample bad;
  bad.rpy_rad.z() = std::nan("");
  auto i = toImuSample(bad, 0, SimWireConfig{});
  ASSERT_FALSE(i.ok());
  EXPECT_NE(i.error().message.find("non-finite"), std::string::npos) << i.error().message;
  sim::DvlSample v;
  v.bottom_lock = true;
  v.velocity_vehicle_mps.x() = std::nan("");
  EXPECT_FALSE(toPd0Ensemble(v, 1, SimWireConfig{}).ok());
}

}  // namespace
}  // namespace vog::vehicle
