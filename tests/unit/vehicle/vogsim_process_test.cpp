// `vogsim vehicle` as a separate process: it writes the endpoints file once every device listens,
// its devices are usable by the real drivers, it answers control lines on its socket, and
// SIGTERM stops it cleanly (exit 0, endpoints file and device links removed) within 2 s.

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

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
#include "vog/sonar/aris_availability.hpp"
#include "vog/sonar/aris_command.hpp"
#include "vog/sonar/aris_frame_assembler.hpp"
#include "vog/vehicle/endpoints.hpp"

namespace vog::vehicle {
namespace {

using namespace std::chrono_literals;

// The endpoints file vogsim writes once every device listens (within 10 s).
Result<VehicleEndpoints> waitForEndpoints(const std::filesystem::path& file) {
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!std::filesystem::exists(file) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(10ms);
  if (!std::filesystem::exists(file)) return Error{"no endpoints file within 10 s"};
  return readEndpointsFile(file);
}

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

  const auto e = waitForEndpoints(endpoints_file);
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

// A UDP socket on 127.0.0.1, ephemeral port (the ARIS test's beacon and frame receiver).
struct ArisProcUdp {
  int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  std::uint16_t port = 0;
  ArisProcUdp() {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    socklen_t len = sizeof(a);
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~ArisProcUdp() { ::close(fd); }
  ArisProcUdp(const ArisProcUdp&) = delete;
  ArisProcUdp& operator=(const ArisProcUdp&) = delete;
  std::optional<std::vector<std::uint8_t>> receive(int timeout_ms) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0) return std::nullopt;
    std::vector<std::uint8_t> buf(65536);
    sockaddr_in from{};
    socklen_t len = sizeof(from);
    const ssize_t n = ::recvfrom(fd, buf.data(), buf.size(), 0, reinterpret_cast<sockaddr*>(&from), &len);
    if (n < 0) return std::nullopt;
    buf.resize(static_cast<std::size_t>(n));
    return buf;
  }
};

// With --sonar-kind aris the vehicle hosts a mock ARIS: the endpoints file says how to reach it,
// it beacons, a client sets it up over TCP and receives the simulator's frames on the ARIS frame
// stream, and the aris control commands and status work.
TEST(VogsimProcessTest, ArisSonarKindSpeaksTheArisLiveProtocol) {
  test::TempDir dir("vog-vogsim");
  const auto endpoints_file = dir.path() / "endpoints.yaml";
  const auto control = dir.path() / "control.sock";
  ArisProcUdp beacons, frames;
  test::Subprocess child({VOGSIM_PATH,
                          "vehicle",
                          "--scene",
                          (test::sourceDir() / "config/scenes/pilings.yaml").string(),
                          "--speedup",
                          "5",
                          "--run-dir",
                          dir.path().string(),
                          "--endpoints",
                          endpoints_file.string(),
                          "--backseat-port",
                          "0",
                          "--sonar-kind",
                          "aris",
                          "--aris-command-port",
                          "0",
                          "--aris-beacon-port",
                          std::to_string(beacons.port),
                          "--aris-serial",
                          "777",
                          "--control",
                          control.string(),
                          "--no-stdin"},
                         {}, dir.path() / "vogsim.log");
  ASSERT_TRUE(child.started());
  const auto e = waitForEndpoints(endpoints_file);
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_EQ(e->sonar_kind, SonarKind::kAris);
  EXPECT_EQ(e->sonar_address, "127.0.0.1");
  EXPECT_NE(e->sonar_command_port, 0);
  EXPECT_EQ(e->sonar_beacon_port, beacons.port);
  EXPECT_EQ(e->sonar_serial_number, 777u);

  auto beacon = beacons.receive(3000);
  ASSERT_TRUE(beacon);
  auto availability = sonar::decodeArisAvailability(*beacon);
  ASSERT_TRUE(availability.ok()) << availability.error().message;
  EXPECT_EQ(availability->serial_number, 777u);

  const int tcp = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(e->sonar_command_port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::connect(tcp, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
  sonar::ArisSettingsCookies cookies;
  auto derived = sonar::deriveArisAcousticSettings(sonar::ArisSonarConfig{});
  ASSERT_TRUE(derived.ok()) << derived.error().message;
  sonar::ArisAcousticSettings acoustics = derived->acoustic;
  cookies.stamp(acoustics);
  for (const sonar::ArisCommand& c : {sonar::ArisCommand{sonar::ArisSetFrameStreamReceiver{"127.0.0.1", frames.port}},
                                      sonar::ArisCommand{acoustics}}) {
    const auto bytes = sonar::encodeArisCommand(c);
    ASSERT_EQ(::send(tcp, bytes.data(), bytes.size(), MSG_NOSIGNAL), static_cast<ssize_t>(bytes.size()));
  }
  sonar::ArisFrameAssembler assembler;
  std::optional<sonar::ArisLiveFrame> got;
  const auto frame_deadline = std::chrono::steady_clock::now() + 5s;
  while (!got && std::chrono::steady_clock::now() < frame_deadline) {
    auto d = frames.receive(100);
    if (!d) continue;
    auto r = assembler.add(*d, 0.0);
    if (r.ack) {
      const auto ack = sonar::encodeArisFramePartAck(*r.ack);
      sockaddr_in to = a;
      to.sin_port = htons(static_cast<std::uint16_t>(r.ack_port));
      ::sendto(frames.fd, ack.data(), ack.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof(to));
    }
    got = std::move(r.frame);
  }
  ASSERT_TRUE(got) << "no ARIS frame within 5 s";
  EXPECT_EQ(got->meta.settings_cookie, acoustics.cookie);
  EXPECT_EQ(got->frame.n_beams, 96);
  EXPECT_EQ(got->frame.n_samples, static_cast<int>(acoustics.samples_per_beam));

  EXPECT_EQ(test::controlRequest(control, "aris loss 0.1").rfind("ok aris loss", 0), 0u);
  const std::string status = test::controlRequest(control, "status");
  EXPECT_NE(status.find("aris_connected=1"), std::string::npos) << status;
  EXPECT_NE(status.find("aris_cookie=" + std::to_string(acoustics.cookie)), std::string::npos) << status;
  EXPECT_NE(status.find("aris_loss=0.1"), std::string::npos) << status;
  const std::string refused = test::controlRequest(control, "fault sonar garbage 1");
  EXPECT_NE(refused.find("error: the sonar is an ARIS"), std::string::npos) << refused;
  EXPECT_EQ(test::controlRequest(control, "aris reboot 1").rfind("ok aris reboot", 0), 0u);
  ::close(tcp);

  child.signal(SIGTERM);
  const int st = child.wait(2.0);
  ASSERT_NE(st, -1) << "vogsim vehicle still running 2 s after SIGTERM";
  EXPECT_EQ(st, 0) << test::readTextFile(dir.path() / "vogsim.log");
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
