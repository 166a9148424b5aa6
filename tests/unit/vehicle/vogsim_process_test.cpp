// `vogsim vehicle` as a separate process: it writes the endpoints file once every device listens,
// its devices are usable by the real drivers, it answers control lines on its socket, and
// SIGTERM stops it cleanly (exit 0, endpoints file and device links removed) within 2 s.

#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "pump.hpp"
#include "subprocess.hpp"
#include "test_support.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/depth/digiquartz.hpp"
#include "vog/io/serial.hpp"
#include "vog/vehicle/endpoints.hpp"

namespace vog::vehicle {
namespace {

using namespace std::chrono_literals;

TEST(VogsimProcessTest, EndpointsDevicesControlAndSigtermWithinTwoSeconds) {
  test::TempDir dir("vog-vogsim");
  const auto endpoints_file = dir.path() / "endpoints.yaml";
  const auto control = dir.path() / "control.sock";
  test::Subprocess child(
      {VOGSIM_PATH, "vehicle", "--scene", (test::sourceDir() / "config/scenes/pilings.yaml").string(), "--seed", "3",
       "--speedup", "10", "--run-dir", dir.path().string(), "--endpoints", endpoints_file.string(), "--backseat-port",
       "0", "--sonar-port", "0", "--control", control.string(), "--no-stdin"},
      {}, dir.path() / "vogsim.log");
  ASSERT_TRUE(child.started());

  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!std::filesystem::exists(endpoints_file) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  ASSERT_TRUE(std::filesystem::exists(endpoints_file)) << "no endpoints file within 10 s";
  auto e = readEndpointsFile(endpoints_file);
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_EQ(e->pid, child.pid());
  EXPECT_EQ(e->seed, 3u);
  EXPECT_EQ(e->scene_name, "pilings");
  EXPECT_DOUBLE_EQ(e->speedup, 10.0);
  EXPECT_NE(e->backseat_port, 0);
  EXPECT_EQ(e->control_socket, control.string());
  EXPECT_TRUE(std::filesystem::is_symlink(e->dvl_device));

  // The depth sensor answers a P3 poll with the start depth (1.5 m, 1 cm sensor noise).
  asio::io_context ioc;
  codec::StreamDecoder<depth::DigiquartzCodec> dq;
  std::vector<double> depths;
  io::SerialConfig sc;
  sc.device_path = e->depth_device;
  sc.baud = e->depth_baud;
  io::SerialTransport port(ioc, sc, io::steadyStampClock(), [&](std::span<const std::uint8_t> b, std::int64_t t) {
    dq.feed(b);
    while (auto m = dq.next()) {
      depth::DepthConversionConfig conv;
      conv.units_code = e->depth_units_code;
      conv.latitude_deg = e->depth_latitude_deg;
      if (auto s = depth::toDepthSample(*m, conv, t)) depths.push_back(s->depth_m);
    }
  });
  ASSERT_TRUE(port.start().ok());
  ASSERT_TRUE(test::pumpUntil(ioc, [&] { return port.health().state == io::LinkState::kConnected; }));
  const std::string p3 = depth::encodeCommand(1, 0, "P3");
  ASSERT_TRUE(port.write(std::vector<std::uint8_t>(p3.begin(), p3.end())).ok());
  ASSERT_TRUE(test::pumpUntil(ioc, [&] { return !depths.empty(); }));
  EXPECT_NEAR(depths.front(), -e->start_xyz_world.z(), 0.05);

  const std::string status = test::controlRequest(control, "status");
  EXPECT_EQ(status.rfind("ok t_s=", 0), 0u) << status;
  const std::string bad = test::controlRequest(control, "unplug gps 2");
  EXPECT_NE(bad.find("error: unknown device 'gps'"), std::string::npos) << bad;
  EXPECT_EQ(test::controlRequest(control, "unplug depth 1").rfind("ok", 0), 0u);
  port.stop();

  const auto t0 = std::chrono::steady_clock::now();
  child.signal(SIGTERM);
  const int st = child.wait(2.0);
  const double stop_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_NE(st, -1) << "vogsim vehicle still running 2 s after SIGTERM";
  EXPECT_EQ(st, 0) << test::readTextFile(dir.path() / "vogsim.log");
  ::testing::Test::RecordProperty("sigterm_to_exit_ms", static_cast<int>(stop_ms));
  EXPECT_FALSE(std::filesystem::exists(endpoints_file));
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(e->dvl_device)));
  EXPECT_FALSE(std::filesystem::exists(e->imu_unix_seqpacket));
  EXPECT_FALSE(std::filesystem::exists(control));
}

TEST(VogsimProcessTest, BadArgumentsFailWithoutStarting) {
  test::TempDir dir("vog-vogsim");
  test::Subprocess child(
      {VOGSIM_PATH, "vehicle", "--scene", (test::sourceDir() / "config/scenes/pilings.yaml").string(), "--speedup", "0",
       "--run-dir", dir.path().string(), "--no-stdin"},
      {}, dir.path() / "vogsim.log");
  const int st = child.wait(10.0);
  ASSERT_NE(st, -1);
  EXPECT_NE(st, 0);
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "endpoints.yaml"));
}

}  // namespace
}  // namespace vog::vehicle
