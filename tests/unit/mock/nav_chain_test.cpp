// The whole navigation input chain: mock DVL (PD0 on a pty), mock IMU (CAN over SOCK_SEQPACKET)
// and mock depth sensor (Digiquartz on a pty), read by the real transports and codecs, feeding
// dead reckoning. Stamps come from an injected clock that follows the simulated time.

#include <gtest/gtest.h>

#include <cmath>

#include "pump.hpp"
#include "test_support.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/io/can.hpp"
#include "vog/io/serial.hpp"
#include "vog/mock/serial_devices.hpp"
#include "vog/mock/socket_devices.hpp"
#include "vog/nav/dead_reckoning.hpp"

namespace vog::mock {
namespace {

using test::pumpUntil;

TEST(NavChainTest, MockDevicesThroughTransportsAndCodecsIntoDeadReckoning) {
  test::TempDir dir("vog-navchain");
  auto dvl = DvlMock::create(dir.path() / "dvl");
  auto depth_mock = DepthMock::create(dir.path() / "depth", 1);
  auto imu_mock = ImuMock::create((dir.path() / "imu.sock").string());
  ASSERT_TRUE(dvl.ok() && depth_mock.ok() && imu_mock.ok());

  asio::io_context ioc;
  std::int64_t sim_now_ns = 0;
  const io::StampClock clock = [&sim_now_ns] { return sim_now_ns; };
  nav::DeadReckoning nav;
  std::uint64_t dvl_n = 0, imu_n = 0, depth_n = 0;

  codec::StreamDecoder<dvl::Pd0Codec> pd0;
  io::SerialConfig dvl_cfg;
  dvl_cfg.device_path = (*dvl)->pty().linkPath().string();
  io::SerialTransport dvl_port(ioc, dvl_cfg, clock, [&](std::span<const std::uint8_t> b, std::int64_t stamp_ns) {
    pd0.feed(b);
    while (auto e = pd0.next()) {
      e->stamp_ns = stamp_ns;
      Status s = nav.addDvl(*e);
      EXPECT_TRUE(s.ok()) << s.error().message;
      ++dvl_n;
    }
  });
  codec::StreamDecoder<depth::DigiquartzCodec> dq;
  io::SerialConfig depth_cfg;
  depth_cfg.device_path = (*depth_mock)->pty().linkPath().string();
  depth_cfg.baud = 9600;
  io::SerialTransport depth_port(ioc, depth_cfg, clock, [&](std::span<const std::uint8_t> b, std::int64_t stamp_ns) {
    dq.feed(b);
    while (auto m = dq.next()) {
      auto sample = depth::toDepthSample(*m, depth::DepthConversionConfig{}, stamp_ns);
      ASSERT_TRUE(sample.ok()) << sample.error().message;
      EXPECT_TRUE(nav.addDepth(*sample).ok());
      ++depth_n;
    }
  });
  codec::StreamDecoder<imu::ImuCanCodec> imu_dec;
  io::CanConfig can_cfg;
  can_cfg.unix_seqpacket = (dir.path() / "imu.sock").string();
  io::CanTransport imu_port(ioc, can_cfg, clock, [&](const can_frame& f, std::int64_t stamp_ns) {
    imu_dec.feed(imu::canFramesToBytes(std::span<const can_frame>(&f, 1)));
    while (auto s = imu_dec.next()) {
      s->stamp_ns = stamp_ns;
      EXPECT_TRUE(nav.addImu(*s).ok());
      ++imu_n;
    }
  });
  ASSERT_TRUE(dvl_port.start().ok() && depth_port.start().ok() && imu_port.start().ok());
  ASSERT_TRUE(pumpUntil(ioc, [&] {
    return dvl_port.health().state == io::LinkState::kConnected &&
           depth_port.health().state == io::LinkState::kConnected &&
           imu_port.health().state == io::LinkState::kConnected && (*imu_mock)->server().clientCount() == 1;
  }));
  const std::string p4 = depth::encodeCommand(1, 0, "P4");
  ASSERT_TRUE(depth_port.write(std::vector<std::uint8_t>(p4.begin(), p4.end())).ok());
  ASSERT_TRUE(pumpUntil(ioc, [&] { return (*depth_mock)->continuous(); }));

  // 5 s heading east (NED heading 90 deg) at 0.2 m/s forward, level, 10 psi gauge-free reading.
  // Default DVL mount: instrument y forward, so the vehicle's forward speed is +y; PD0 reports the
  // bottom's motion, i.e. -0.2 m/s.
  for (int k = 0; k <= 500; ++k) {
    sim_now_ns = static_cast<std::int64_t>(k) * 10'000'000;
    imu::ImuSample s;
    s.sequence = static_cast<std::uint32_t>(k & 0xFF);
    s.attitude = imu::ImuAttitude{0.0, 0.0, M_PI / 2};
    s.angular_rate_radps = Eigen::Vector3d::Zero();
    const std::uint64_t imu_before = imu_n;
    ASSERT_TRUE((*imu_mock)->send(s).ok());
    ASSERT_TRUE(pumpUntil(ioc, [&] { return imu_n > imu_before; }));
    if (k % 20 == 0) {
      dvl::DvlEnsemble e;
      e.fixed.coordinate_transform = 0x08;
      e.fixed.coordinate_frame = dvl::CoordinateFrame::kInstrument;
      e.variable.ensemble_number = static_cast<std::uint32_t>(k / 20 + 1);
      e.variable.clock = dvl::DvlClock{2026, 11, 21, 12, 0, 0, 0};
      dvl::DvlBottomTrack bt;
      bt.velocity_mps = {0.0, -0.2, 0.0, 0.0};
      bt.velocity_valid = {true, true, true, true};
      e.bottom_track = bt;
      const std::uint64_t before = dvl_n;
      ASSERT_TRUE((*dvl)->sendPd0(e).ok());
      ASSERT_TRUE(pumpUntil(ioc, [&] { return dvl_n > before; }));
    }
    if (k % 25 == 0) {
      const std::uint64_t before = depth_n;
      (*depth_mock)->setPressure(14.696 + 10.0);  // absolute psi: about 10 psi of sea water
      ASSERT_TRUE(pumpUntil(ioc, [&] { return depth_n > before; }));
    }
  }
  const nav::NavSolution sol = nav.solution(sim_now_ns);
  EXPECT_FALSE(sol.degraded) << sol.reason;
  EXPECT_EQ(sol.dvl_used, 26u);
  EXPECT_EQ(sol.dvl_rejected, 0u);
  // 5 s east at 0.2 m/s; attitude quantised to 1e-4 rad on the CAN wire.
  EXPECT_NEAR(sol.T_world_vehicle.translation().x(), 1.0, 1e-3);
  EXPECT_NEAR(sol.T_world_vehicle.translation().y(), 0.0, 1e-3);
  // 10 psi = 68.95 kPa of sea water: about 6.86 m (UNESCO 1983 at 42 deg latitude).
  EXPECT_NEAR(sol.T_world_vehicle.translation().z(), -6.86, 0.05);
}

}  // namespace
}  // namespace vog::mock
