// IMU (SOCK_SEQPACKET CAN stand-in), sonar (UDP) and backseat (TCP) mocks read back through the
// real transports and codecs, with every fault kind and a disappearing device.

#include <gtest/gtest.h>

#include <map>
#include <set>

#include "pump.hpp"
#include "test_support.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/io/can.hpp"
#include "vog/io/tcp_client.hpp"
#include "vog/io/udp.hpp"
#include "vog/mock/socket_devices.hpp"
#include "vog/sonar/sonar_udp.hpp"

namespace vog::mock {
namespace {

using test::pumpUntil;

imu::ImuSample imuSample(std::uint32_t seq) {
  imu::ImuSample s;
  s.sequence = seq;
  s.attitude = imu::ImuAttitude{0.01 * seq, -0.02, 1.0 + 0.001 * seq};
  s.angular_rate_radps = Eigen::Vector3d(0.1, -0.1, 0.05);
  s.delta_velocity_mps = Eigen::Vector3d(0.001, 0.0, -0.098);
  s.dt_s = 0.01;
  return s;
}

TEST(ImuMockTest, CanOverSeqpacketWithEveryFaultAndReconnect) {
  test::TempDir dir("vog-imu");
  const std::string path = (dir.path() / "imu.sock").string();
  auto mock = ImuMock::create(path, {}, 5);
  ASSERT_TRUE(mock.ok()) << mock.error().message;
  asio::io_context ioc;
  codec::StreamDecoder<imu::ImuCanCodec> decoder;
  std::map<std::uint32_t, imu::ImuSample> got;
  io::CanConfig c;
  c.unix_seqpacket = path;
  c.filters = {io::CanFilter{imu::can_layout::kDefaultBaseId, 0x7FC}};  // base + 0..3
  c.reconnect.initial_delay_ms = 5;
  c.reconnect.max_delay_ms = 20;
  io::CanTransport can(ioc, c, io::steadyStampClock(), [&](const can_frame& f, std::int64_t stamp_ns) {
    decoder.feed(imu::canFramesToBytes(std::span<const can_frame>(&f, 1)));
    while (auto s = decoder.next()) {
      s->stamp_ns = stamp_ns;
      got[s->sequence] = *s;
    }
  });
  ASSERT_TRUE(can.start().ok());
  ASSERT_TRUE(pumpUntil(
      ioc, [&] { return can.health().state == io::LinkState::kConnected && (*mock)->server().clientCount() == 1; }));

  const std::map<std::uint32_t, Fault> faults = {
      {2, Fault::kGarbage}, {4, Fault::kTruncate}, {6, Fault::kBadChecksum}, {8, Fault::kDropout}};
  for (std::uint32_t seq = 0; seq < 12; ++seq) {
    if (auto f = faults.find(seq); f != faults.end()) (*mock)->faults().inject(f->second);
    ASSERT_TRUE((*mock)->send(imuSample(seq)).ok());
  }
  ASSERT_TRUE(pumpUntil(ioc, [&] { return got.count(11) == 1; })) << got.size();
  for (std::uint32_t seq : {0u, 1u, 2u, 3u, 5u, 7u, 9u, 10u, 11u}) EXPECT_EQ(got.count(seq), 1u) << seq;
  for (std::uint32_t seq : {4u, 6u, 8u}) EXPECT_EQ(got.count(seq), 0u) << seq;
  EXPECT_GE(decoder.stats().bad_checksum, 1u);
  EXPECT_GE(can.health().errors, 1u);  // the 7-byte record of the garbage fault
  for (const auto& [seq, s] : got) {
    ASSERT_TRUE(s.attitude.has_value());
    EXPECT_NEAR(s.attitude->roll_rad, 0.01 * seq, 1e-4);
    EXPECT_NEAR(s.attitude->yaw_rad, 1.0 + 0.001 * seq, 1e-4);
    EXPECT_NEAR(s.delta_velocity_mps.z(), -0.098, 1e-5);
  }

  // The IMU node goes away (socket closed and path removed) and comes back.
  (*mock)->server().disappear();
  ASSERT_TRUE(pumpUntil(ioc, [&] { return can.health().state != io::LinkState::kConnected; }));
  ASSERT_TRUE((*mock)->server().reappear().ok());
  ASSERT_TRUE(pumpUntil(
      ioc, [&] { return can.health().state == io::LinkState::kConnected && (*mock)->server().clientCount() == 1; }));
  decoder.reset();
  ASSERT_TRUE((*mock)->send(imuSample(12)).ok());
  ASSERT_TRUE(pumpUntil(ioc, [&] { return got.count(12) == 1; }));
  EXPECT_EQ(can.health().connects, 2u);
}

sonar::SonarFrame sonarFrame(std::uint32_t index) {
  sonar::SonarFrame f;
  f.frame_index = index;
  f.stamp_ns = 1'000'000'000LL + index * 100'000'000LL;
  f.n_beams = 96;
  f.n_samples = 512;
  f.window_start_m = 0.75;
  f.window_length_m = 9.0;
  f.samples.resize(96 * 512);
  for (std::size_t i = 0; i < f.samples.size(); ++i)
    f.samples[i] = static_cast<std::uint8_t>((i * 31 + index * 7) & 0xFF);
  return f;
}

TEST(SonarMockTest, FramesOverUdpWithEveryFault) {
  asio::io_context ioc;
  const sonar::SonarUdpCodec codec;
  sonar::FrameReassembler reassembler(8);
  std::map<std::uint32_t, sonar::SonarFrame> got;
  std::uint64_t bad_datagrams = 0;
  io::UdpReceiver rx(ioc, io::UdpReceiverConfig{}, io::steadyStampClock(),
                     [&](std::span<const std::uint8_t> d, std::int64_t) {
                       auto r = codec.decode(d);
                       if (!r.isFrame() || r.consumed() != d.size()) {
                         ++bad_datagrams;
                         return;
                       }
                       if (auto frame = reassembler.add(r.frame())) got[frame->frame_index] = std::move(*frame);
                     });
  ASSERT_TRUE(rx.start().ok());
  auto mock = SonarMock::create(rx.localPort(), 9);
  ASSERT_TRUE(mock.ok()) << mock.error().message;

  const std::map<std::uint32_t, Fault> faults = {
      {1, Fault::kGarbage}, {2, Fault::kTruncate}, {3, Fault::kBadChecksum}, {4, Fault::kDropout}};
  for (std::uint32_t i = 0; i < 7; ++i) {
    if (auto f = faults.find(i); f != faults.end()) (*mock)->faults().inject(f->second);
    ASSERT_TRUE((*mock)->send(sonarFrame(i)).ok());
    // Pace the sender by the receiver so no datagram is lost to a full socket buffer.
    ASSERT_TRUE(pumpUntil(ioc, [&] { return rx.health().frames_rx + rx.health().errors >= (*mock)->datagramsSent(); }));
  }
  for (std::uint32_t i : {0u, 1u, 5u, 6u}) {
    ASSERT_EQ(got.count(i), 1u) << i;
    EXPECT_EQ(got[i].samples, sonarFrame(i).samples) << i;
    EXPECT_EQ(got[i].stamp_ns, sonarFrame(i).stamp_ns);
  }
  for (std::uint32_t i : {2u, 3u, 4u}) EXPECT_EQ(got.count(i), 0u) << i;
  EXPECT_EQ(bad_datagrams, 3u);  // noise, truncated fragment, bad CRC

  (*mock)->disappear();
  ASSERT_TRUE((*mock)->send(sonarFrame(7)).ok());  // silent
  ASSERT_TRUE((*mock)->reappear().ok());
  ASSERT_TRUE((*mock)->send(sonarFrame(8)).ok());
  ASSERT_TRUE(pumpUntil(ioc, [&] { return got.count(8) == 1; }));
  EXPECT_EQ(got.count(7), 0u);
}

TEST(BackseatMockTest, SentencesOverTcpWithFaultsAcksAndReconnect) {
  auto mock = BackseatMock::create(0, 11);
  ASSERT_TRUE(mock.ok()) << mock.error().message;
  asio::io_context ioc;
  codec::StreamDecoder<backseat::BackseatCodec> decoder;
  std::vector<backseat::NavSentence> navs;
  std::vector<backseat::AckSentence> acks;
  io::TcpClientConfig c;
  c.port = (*mock)->server().port();
  c.reconnect.initial_delay_ms = 5;
  c.reconnect.max_delay_ms = 20;
  io::TcpClient client(ioc, c, io::steadyStampClock(), [&](std::span<const std::uint8_t> b, std::int64_t) {
    decoder.feed(b);
    while (auto s = decoder.next()) {
      if (auto* n = std::get_if<backseat::NavSentence>(&*s)) navs.push_back(*n);
      if (auto* a = std::get_if<backseat::AckSentence>(&*s)) acks.push_back(*a);
    }
  });
  ASSERT_TRUE(client.start().ok());
  ASSERT_TRUE(pumpUntil(
      ioc, [&] { return client.health().state == io::LinkState::kConnected && (*mock)->server().clientCount() == 1; }));

  const std::map<int, Fault> faults = {
      {2, Fault::kGarbage}, {4, Fault::kTruncate}, {6, Fault::kBadChecksum}, {8, Fault::kDropout}};
  for (int i = 0; i < 11; ++i) {
    if (auto f = faults.find(i); f != faults.end()) (*mock)->faults().inject(f->second);
    backseat::NavSentence n;
    n.time.seconds_since_midnight = 3600.0 + i;
    n.latitude_deg = 42.35;
    n.longitude_deg = -71.05;
    n.depth_m = 2.0 + i;
    n.heading_deg = 90;
    (*mock)->send(n);
  }
  ASSERT_TRUE(pumpUntil(ioc, [&] { return !navs.empty() && navs.back().depth_m == 12.0; }));
  std::set<double> depths;
  for (const auto& n : navs) depths.insert(n.depth_m);
  for (int i : {0, 1, 2, 3, 7, 9, 10}) EXPECT_EQ(depths.count(2.0 + i), 1u) << i;  // 5 may follow a truncation
  for (int i : {4, 6, 8}) EXPECT_EQ(depths.count(2.0 + i), 0u) << i;
  EXPECT_GE(decoder.stats().bad_checksum, 1u);

  // Payload -> vehicle: a waypoint command is acknowledged by the vehicle.
  backseat::AckTracker tracker;
  backseat::WaypointCommand cmd;
  cmd.id = 77;
  cmd.latitude_deg = 42.35;
  cmd.longitude_deg = -71.05;
  cmd.depth_m = 3.0;
  cmd.speed_mps = 0.25;
  auto line = tracker.send(cmd, 0);
  ASSERT_TRUE(line.ok());
  ASSERT_TRUE(client.write(std::vector<std::uint8_t>(line->begin(), line->end())).ok());
  ASSERT_TRUE(pumpUntil(ioc, [&] { return !acks.empty(); }));
  auto outcome = tracker.onAck(acks.front());
  ASSERT_TRUE(outcome.ok()) << outcome.error().message;
  EXPECT_TRUE(outcome->accepted);
  EXPECT_EQ(outcome->command_id, 77u);
  ASSERT_EQ((*mock)->received().size(), 1u);

  // The vehicle's server restarts: the payload reconnects by itself.
  (*mock)->server().disappear();
  ASSERT_TRUE(pumpUntil(ioc, [&] { return client.health().state != io::LinkState::kConnected; }));
  ASSERT_TRUE((*mock)->server().reappear().ok());
  ASSERT_TRUE(pumpUntil(
      ioc, [&] { return client.health().state == io::LinkState::kConnected && (*mock)->server().clientCount() == 1; }));
  decoder.reset();
  backseat::NavSentence n;
  n.depth_m = 99.0;
  (*mock)->send(n);
  ASSERT_TRUE(pumpUntil(ioc, [&] { return navs.back().depth_m == 99.0; }));
  EXPECT_EQ(client.health().connects, 2u);
}

}  // namespace
}  // namespace vog::mock
