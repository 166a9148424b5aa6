// The device backend's decoding (DeviceFeed) on the devices' real wire formats, built with the same
// encoders the mock devices use: a vehicle moving east at 0.2 m/s, 2 m deep, with IMU CAN frames,
// PD0 ensembles, Digiquartz replies, $BFNVG sentences (its navigation 0.5 m east of the truth) and
// sonar frames over the fragment format. Checked: the alignment to the vehicle's navigation, the
// poses of the scans against the truth, the ranges, what is dropped and why, and that the same
// chunks give the same outputs bit for bit (what `vogd --replay` relies on).
#include "vog/app/device_feed.hpp"

#include "vog/backseat/backseat.hpp"
#include "vog/backseat/local_tangent_plane.hpp"
#include "vog/depth/digiquartz.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/imu/imu_can.hpp"
#include "vog/mock/aris_frame_sender.hpp"
#include "vog/sonar/aris_command.hpp"
#include "vog/sonar/sonar_udp.hpp"
#include "vog/vehicle/sim_wire.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace vog::app {
namespace {

constexpr std::int64_t kMs = 1'000'000;
constexpr double kSpeed = 0.2;
constexpr double kDepth = 2.0;
constexpr double kX0 = -3.0;
constexpr double kNavOffsetEast = 0.5;  // the vehicle's navigation is this far east of the truth
constexpr double kRange = 3.0;          // every beam sees a return at 3 m

struct Chunk {
  DeviceId device;
  std::int64_t stamp_ns;
  std::vector<std::uint8_t> bytes;
};

double trueX(std::int64_t t_ns) { return kX0 + kSpeed * 1e-9 * static_cast<double>(t_ns); }

std::vector<std::uint8_t> bytesOf(const std::string& s) { return {s.begin(), s.end()}; }

sonar::SonarFrame frameAt(std::int64_t t_ns, std::uint32_t index, int n_beams) {
  sonar::SonarFrame f;
  f.stamp_ns = t_ns;
  f.frame_index = index;
  f.n_beams = n_beams;
  f.n_samples = 512;
  // Whole microseconds at 1500 m/s (0.75 mm each), as an ARIS header carries them: a delay of 670 us
  // and a sample period of 27 us (2.025 cm samples).
  f.window_start_m = 0.5025;
  f.window_length_m = 512 * 0.02025;
  f.samples.assign(static_cast<std::size_t>(f.n_beams * f.n_samples), 10);
  const int s0 = static_cast<int>((kRange - f.window_start_m) / f.sampleLength_m());
  for (int s = s0; s < s0 + 4; ++s)
    for (int b = 0; b < f.n_beams; ++b) f.samples[static_cast<std::size_t>(s * f.n_beams + b)] = 200;
  return f;
}

enum class SonarWire { kFragments, kAris };
constexpr std::uint32_t kArisCookie = 7;
constexpr std::int32_t kArisAckPort = 56889;

// 20 s of the vehicle's devices, in reception order: each stamped a few ms after it was taken
// (IMU 0, depth 1, DVL 2, backseat 3, sonar 5 ms). Navigation sentences start at 1 s, so frames 1-5
// come before them; frame 50 has 48 beams; 64 garbage bytes precede the DVL at 8 s.
// kAris: the frames as an ARIS sends them (FramePart datagrams in the sonar's order), after the
// SET_ACOUSTICS with cookie 7 that vogd logged at 0; frames 10-12 still carry cookie 6.
std::vector<Chunk> recording(SonarWire sonar_wire = SonarWire::kFragments) {
  std::vector<Chunk> out;
  mock::ArisFrameSender aris(
      {.mode = sonar::ArisPacketLossMitigation::kDropPartialFrames, .part_bytes = 8192, .ack_port = kArisAckPort});
  if (sonar_wire == SonarWire::kAris) {
    sonar::ArisAcousticSettings settings = sonar::deriveArisAcousticSettings({}).value().acoustic;
    settings.cookie = kArisCookie;
    out.push_back({DeviceId::kArisCommands, 0, sonar::encodeArisCommand(settings)});
  }
  vehicle::SimWireConfig wire;
  const auto ltp = backseat::LocalTangentPlane::create({42.0, -71.0}).value();
  std::uint32_t imu_seq = 0, ensemble = 0, frame = 0;
  for (std::int64_t t = 0; t <= 20'000 * kMs; t += 10 * kMs) {
    sim::ImuSample imu;
    imu.stamp_ns = t;
    auto sample = vehicle::toImuSample(imu, imu_seq++, wire).value();
    const auto frames = imu::encodeImuCan(sample).value();
    for (const can_frame& f : frames)
      out.push_back({DeviceId::kImu, t, imu::canFramesToBytes(std::span<const can_frame>(&f, 1))});
    if (t % (100 * kMs) == 0) {
      const double reading = vehicle::toDigiquartzReading({t, kDepth}, wire).value();
      out.push_back({DeviceId::kDepth, t + 1 * kMs, bytesOf(depth::encodePressureReply(0, 1, reading, 4))});
    }
    if (t % (200 * kMs) == 0) {
      if (t == 8'000 * kMs) out.push_back({DeviceId::kDvl, t + 2 * kMs, std::vector<std::uint8_t>(64, 0x55)});
      sim::DvlSample d{t, true, Eigen::Vector3d(kSpeed, 0, 0), 3.0};
      const auto e = vehicle::toPd0Ensemble(d, ++ensemble, wire).value();
      out.push_back({DeviceId::kDvl, t + 2 * kMs, dvl::encodePd0(e)});
      if (t >= 1'000 * kMs) {
        backseat::NavSentence n;
        const backseat::GeoPoint g = ltp.toGeo(Eigen::Vector2d(trueX(t) + kNavOffsetEast, 0.0));
        n.latitude_deg = g.latitude_deg;
        n.longitude_deg = g.longitude_deg;
        n.depth_m = kDepth;
        n.heading_deg = 90.0;  // east
        out.push_back({DeviceId::kBackseat, t + 3 * kMs, bytesOf(backseat::encodeBackseat(n))});
        backseat::NavRateSentence r;
        r.east_mps = kSpeed;
        out.push_back({DeviceId::kBackseat, t + 3 * kMs, bytesOf(backseat::encodeBackseat(r))});
      }
    }
    if (t % (200 * kMs) == 100 * kMs) {
      ++frame;
      const sonar::SonarFrame f = frameAt(t, frame, frame == 50 ? 48 : 96);
      if (sonar_wire == SonarWire::kAris) {
        const sonar::ArisHeaderOptions header{.ping_mode = f.n_beams == 48 ? 1u : 3u,
                                              .reordered_samples = false,
                                              .settings_cookie = frame >= 10 && frame <= 12 ? 6 : kArisCookie};
        const auto datagrams = aris.send(f, header, 1e-9 * static_cast<double>(t));
        if (!datagrams) throw std::runtime_error(datagrams.error().message);
        for (const auto& datagram : *datagrams) out.push_back({DeviceId::kArisFrames, t + 5 * kMs, datagram});
      } else {
        const auto datagrams = sonar::encodeSonarDatagrams(f);
        for (const auto& datagram : datagrams.value()) out.push_back({DeviceId::kSonar, t + 5 * kMs, datagram});
      }
    }
  }
  return out;
}

struct FeedRun {
  std::vector<OdometrySample> odometry;
  std::vector<slam::ScanInput> scans;
  std::vector<ArisAckOut> aris_acks;
};

FeedRun feedAll(DeviceFeed& feed, const std::vector<Chunk>& chunks) {
  FeedRun run;
  FeedOutput out;
  for (const Chunk& c : chunks) {
    out.clear();
    feed.feed(c.device, c.stamp_ns, c.bytes, out);
    run.odometry.insert(run.odometry.end(), out.odometry.begin(), out.odometry.end());
    run.scans.insert(run.scans.end(), out.scans.begin(), out.scans.end());
    run.aris_acks.insert(run.aris_acks.end(), out.aris_acks.begin(), out.aris_acks.end());
  }
  return run;
}

DeviceFeedConfig feedConfig() {
  DeviceFeedConfig c;
  c.origin = {42.0, -71.0};
  c.depth = vehicle::SimWireConfig{}.depth;
  return c;
}

TEST(DeviceFeed, ScansAreMappedAtTheAlignedDeadReckoningPose) {
  auto feed = DeviceFeed::create(feedConfig());
  ASSERT_TRUE(feed.ok()) << feed.error().message;
  const FeedRun run = feedAll(*feed, recording());

  // 100 pings: the five before the vehicle's navigation and the 48-beam one are dropped.
  EXPECT_EQ(feed->scans(), 94u);
  EXPECT_EQ(feed->scansDropped(), 6u);
  ASSERT_EQ(run.scans.size(), 94u);
  EXPECT_TRUE(feed->aligned());
  EXPECT_GE(feed->counters(DeviceId::kSonar).rejected, 1u);
  EXPECT_NE(feed->counters(DeviceId::kSonar).last_error.find("48 beams"), std::string::npos)
      << feed->counters(DeviceId::kSonar).last_error;

  double worst_m = 0.0;
  for (const slam::ScanInput& s : run.scans) {
    const std::int64_t t = s.scan.stamp_ns;
    // The odometry frame is the vehicle's navigation frame: the truth shifted 0.5 m east. Aligned at
    // a $BFNVG stamped 3 ms late, dead reckoning runs 3 ms behind its stamps.
    const Eigen::Vector3d expected(trueX(t - 3 * kMs) + kNavOffsetEast, 0.0, -kDepth);
    worst_m = std::max(worst_m, (s.T_world_vehicle_odom.translation() - expected).norm());
    EXPECT_NEAR(geometry::yawOf(s.T_world_vehicle_odom.linear()), 0.0, 1e-3);
    EXPECT_NEAR(s.z_roll_pitch.x(), -kDepth, 0.01);
    ASSERT_EQ(s.scan.range_m.size(), 96u);
    for (float r : s.scan.range_m) EXPECT_NEAR(r, kRange, 0.03);
  }
  // PD0 carries mm/s, the sentences 2 mm.
  EXPECT_LT(worst_m, 0.005);

  // Odometry follows the DVL from the alignment on, in stamp order.
  ASSERT_GT(run.odometry.size(), 90u);
  for (std::size_t i = 1; i < run.odometry.size(); ++i)
    EXPECT_GE(run.odometry[i].stamp_ns, run.odometry[i - 1].stamp_ns);
  // Garbage before an ensemble is skipped and decoding goes on.
  EXPECT_GE(feed->droppedInput(DeviceId::kDvl), 64u);
  EXPECT_EQ(feed->deadReckoning(20'002 * kMs).dvl_used, 101u);
  EXPECT_FALSE(feed->deadReckoning(20'002 * kMs).degraded) << feed->deadReckoning(20'002 * kMs).reason;
}

TEST(DeviceFeed, TheSameChunksGiveTheSameScansBitForBit) {
  const std::vector<Chunk> chunks = recording();
  auto a = DeviceFeed::create(feedConfig()).value();
  auto b = DeviceFeed::create(feedConfig()).value();
  const FeedRun ra = feedAll(a, chunks);
  const FeedRun rb = feedAll(b, chunks);
  ASSERT_EQ(ra.scans.size(), rb.scans.size());
  for (std::size_t i = 0; i < ra.scans.size(); ++i) {
    EXPECT_EQ(ra.scans[i].scan.stamp_ns, rb.scans[i].scan.stamp_ns);
    EXPECT_EQ(std::memcmp(ra.scans[i].T_world_vehicle_odom.data(), rb.scans[i].T_world_vehicle_odom.data(),
                          16 * sizeof(double)),
              0);
    EXPECT_EQ(ra.scans[i].scan.range_m, rb.scans[i].scan.range_m);
  }
}

// The same pings over the ARIS frame stream: each datagram acknowledged to its ack port, the frames
// reordered from the sonar's order, and the same scans as over the fragment format at the same
// stamps and poses (the window in whole microseconds, as a header holds it). Frames made with settings other than the
// last sent are not mapped.
TEST(DeviceFeed, ArisFrameStreamGivesTheSameScansAndOnlyWithTheSettingsSent) {
  auto fragments = DeviceFeed::create(feedConfig()).value();
  const FeedRun reference = feedAll(fragments, recording(SonarWire::kFragments));
  const std::vector<Chunk> chunks = recording(SonarWire::kAris);
  auto feed = DeviceFeed::create(feedConfig()).value();
  const FeedRun run = feedAll(feed, chunks);

  const auto parts =
      std::count_if(chunks.begin(), chunks.end(), [](const Chunk& c) { return c.device == DeviceId::kArisFrames; });
  ASSERT_EQ(run.aris_acks.size(), static_cast<std::size_t>(parts));
  for (const ArisAckOut& a : run.aris_acks) {
    EXPECT_EQ(a.port, kArisAckPort);
    EXPECT_TRUE(sonar::decodeArisFramePartAck(a.datagram).ok());
  }
  EXPECT_EQ(feed.arisCookieSent(), kArisCookie);
  EXPECT_EQ(feed.arisCookieReceived(), kArisCookie);
  EXPECT_EQ(feed.arisFrames().frames_completed, 100u);
  EXPECT_EQ(feed.arisFramesOtherSettings(), 3u);
  EXPECT_EQ(feed.lastDropReason(), "beam count");  // frame 50, after frames 10-12
  EXPECT_EQ(feed.counters(DeviceId::kArisCommands).messages, 1u);
  // Settings sent again (a reconnection, perhaps to a rebooted sonar): no frame has shown them yet.
  sonar::ArisAcousticSettings resent = sonar::deriveArisAcousticSettings({}).value().acoustic;
  resent.cookie = kArisCookie;
  FeedOutput none;
  feed.feed(DeviceId::kArisCommands, 30'000 * kMs, sonar::encodeArisCommand(resent), none);
  EXPECT_EQ(feed.arisCookieReceived(), 0u);

  ASSERT_EQ(run.scans.size(), 91u);  // 94 as over fragments, less frames 10-12
  std::size_t j = 0;
  for (const slam::ScanInput& s : run.scans) {
    while (j < reference.scans.size() && reference.scans[j].scan.stamp_ns < s.scan.stamp_ns) ++j;
    ASSERT_LT(j, reference.scans.size());
    const slam::ScanInput& r = reference.scans[j];
    ASSERT_EQ(r.scan.stamp_ns, s.scan.stamp_ns);
    EXPECT_EQ(std::memcmp(r.T_world_vehicle_odom.data(), s.T_world_vehicle_odom.data(), 16 * sizeof(double)), 0);
    ASSERT_EQ(s.scan.range_m.size(), r.scan.range_m.size());
    for (std::size_t b = 0; b < s.scan.range_m.size(); ++b) EXPECT_NEAR(s.scan.range_m[b], r.scan.range_m[b], 1e-5);
  }

  // The same chunks again: the same scans bit for bit (what --replay relies on).
  auto again = DeviceFeed::create(feedConfig()).value();
  const FeedRun rerun = feedAll(again, chunks);
  ASSERT_EQ(rerun.scans.size(), run.scans.size());
  for (std::size_t i = 0; i < run.scans.size(); ++i) EXPECT_EQ(rerun.scans[i].scan.range_m, run.scans[i].scan.range_m);
}

TEST(DeviceFeed, DamagedArisInputIsCountedAndNamed) {
  auto feed = DeviceFeed::create(feedConfig()).value();
  FeedOutput out;
  feed.feed(DeviceId::kArisFrames, 1 * kMs, std::vector<std::uint8_t>(40, 0xFF), out);
  EXPECT_EQ(feed.counters(DeviceId::kArisFrames).rejected, 1u);
  EXPECT_NE(feed.counters(DeviceId::kArisFrames).last_error.find("not a FramePart"), std::string::npos)
      << feed.counters(DeviceId::kArisFrames).last_error;
  EXPECT_TRUE(out.aris_acks.empty());
  std::vector<std::uint8_t> cut = sonar::encodeArisCommand(sonar::ArisPing{});
  cut.pop_back();
  feed.feed(DeviceId::kArisCommands, 2 * kMs, cut, out);
  EXPECT_EQ(feed.counters(DeviceId::kArisCommands).rejected, 1u);
  EXPECT_EQ(feed.arisCookieSent(), 0u);
}

TEST(DeviceFeed, BackseatNavigationIsInterpolatedToThePing) {
  DeviceFeedConfig c = feedConfig();
  c.navigation = NavigationSource::kBackseat;
  auto feed = DeviceFeed::create(c).value();
  const FeedRun run = feedAll(feed, recording());
  ASSERT_EQ(run.scans.size(), 94u);
  for (const slam::ScanInput& s : run.scans) {
    // $BFNVG is stamped 3 ms late; its position has 2 mm resolution.
    const Eigen::Vector3d expected(trueX(s.scan.stamp_ns - 3 * kMs) + kNavOffsetEast, 0.0, -kDepth);
    EXPECT_LT((s.T_world_vehicle_odom.translation() - expected).norm(), 0.005) << s.scan.stamp_ns;
  }
  EXPECT_EQ(run.odometry.size(), 96u);  // one per $BFNVG
}

// Damaged or impossible input stops at the feed: a sentence with a NaN or a bad checksum, a sonar
// datagram cut short, a PD0 ensemble with a broken checksum; each is counted, nothing is mapped
// from it, and decoding goes on.
TEST(DeviceFeed, DamagedInputIsCountedAndNothingIsMappedFromIt) {
  auto feed = DeviceFeed::create(feedConfig()).value();
  FeedOutput out;
  auto sentence = [](const std::string& body) {
    char hh[3];
    std::snprintf(hh, sizeof hh, "%02X", backseat::xorChecksum(body));
    return bytesOf("$" + body + "*" + hh + "\r\n");
  };
  feed.feed(DeviceId::kBackseat, 1 * kMs,
            sentence("BFNVG,000000.00,4200.000000,N,07100.000000,W,0,3.00,nan,90.00,0.00,0.00,000000.00"), out);
  EXPECT_FALSE(out.vehicle_navigation.has_value());  // the decoder drops it as malformed
  EXPECT_EQ(feed.droppedInput(DeviceId::kBackseat), 1u);
  std::vector<std::uint8_t> bad =
      sentence("BFNVG,000000.00,4200.000000,N,07100.000000,W,0,3.00,2.00,90.00,0.00,0.00,000000.00");
  bad[bad.size() - 3] ^= 0x01;  // checksum digit
  feed.feed(DeviceId::kBackseat, 2 * kMs, bad, out);
  EXPECT_FALSE(out.vehicle_navigation.has_value());
  EXPECT_EQ(feed.droppedInput(DeviceId::kBackseat), 2u);  // one bad frame each

  const auto datagrams = sonar::encodeSonarDatagrams(frameAt(0, 1, 96));
  std::vector<std::uint8_t> cut = datagrams.value().front();
  cut.resize(cut.size() / 2);
  feed.feed(DeviceId::kSonar, 3 * kMs, cut, out);
  EXPECT_EQ(feed.counters(DeviceId::kSonar).rejected, 1u);

  vehicle::SimWireConfig wire;
  std::vector<std::uint8_t> pd0 =
      dvl::encodePd0(vehicle::toPd0Ensemble({0, true, Eigen::Vector3d(0.2, 0, 0), 3.0}, 1, wire).value());
  pd0[20] ^= 0xFF;
  feed.feed(DeviceId::kDvl, 4 * kMs, pd0, out);
  EXPECT_EQ(feed.counters(DeviceId::kDvl).messages, 0u);
  EXPECT_GT(feed.droppedInput(DeviceId::kDvl), 0u);
  EXPECT_TRUE(out.scans.empty());
  EXPECT_TRUE(out.odometry.empty());

  // And the good data after it is decoded.
  const FeedRun run = feedAll(feed, recording());
  EXPECT_EQ(run.scans.size(), 94u);
}

TEST(DeviceFeed, BadConfigurationIsNamed) {
  DeviceFeedConfig c = feedConfig();
  c.origin.latitude_deg = 89.0;
  auto f = DeviceFeed::create(c);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("devices.backseat.origin"), std::string::npos) << f.error().message;
  c = feedConfig();
  c.depth.units_code = 42;
  f = DeviceFeed::create(c);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("devices.depth"), std::string::npos) << f.error().message;
}

}  // namespace
}  // namespace vog::app
