// Hardware in the loop with mock devices: `vogsim vehicle` (the simulated propeller and vehicle behind
// the real wire protocols: PD0 and Digiquartz on ptys, IMU CAN frames on the SEQPACKET stand-in,
// sonar fragments over UDP, the backseat over TCP) and `vogd` (source: devices, its real drivers on
// those endpoints) run as separate processes, and the operator drives a short mission with
// `vogctl`. The mission reaches several submaps and a loop closure, vogctl fetches a snapshot and
// a cloud, injected garbage and an unplugged IMU are survived, and `kill -9` of vogd mid-mission
// followed by a restart resumes with no closed submap lost and the mission going on.
#include "subprocess.hpp"
#include "test_support.hpp"
#include "vog/vehicle/endpoints.hpp"

#include <Eigen/Core>
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <fstream>
#include <functional>
#include <optional>
#include <regex>
#include <set>
#include <thread>

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using vog::test::Subprocess;

constexpr double kSpeedup = 4.0;
// The propeller scene's exploration box: the vehicle circles the blades, so submaps overlap early.
constexpr const char* kBox = "-6,-4.5,-8.5,6,4.5,-0.5";
constexpr const char* kSecret = "bench-operator-secret-0123456789";

// The vertices of vogctl's binary little-endian PLY (x y z floats first); empty if it is not one.
std::vector<Eigen::Vector3f> readBinaryPly(const fs::path& file) {
  const std::string bytes = vog::test::readTextFile(file);
  std::smatch m;
  if (bytes.rfind("ply\nformat binary_little_endian 1.0\n", 0) != 0 ||
      !std::regex_search(bytes, m, std::regex("element vertex ([0-9]+)\n")))
    return {};
  const std::size_t n = std::stoul(m[1]);
  const std::size_t stride = bytes.find("property float nx") == std::string::npos ? 12 : 24;
  const std::size_t header_end = bytes.find("end_header\n");
  if (header_end == std::string::npos) return {};
  const std::size_t body = header_end + std::strlen("end_header\n");
  if (bytes.size() != body + n * stride) return {};
  std::vector<Eigen::Vector3f> points(n);
  for (std::size_t i = 0; i < n; ++i) std::memcpy(points[i].data(), bytes.data() + body + i * stride, 12);
  return points;
}

// A UDP port nobody uses right now (vogd binds it for the sonar; vogsim sends to it).
std::uint16_t freeUdpPort() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a);
  socklen_t len = sizeof a;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(fd);
  return ntohs(a.sin_port);
}

bool waitUntil(const std::function<bool()>& done, double timeout_s) {
  const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (Clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  return done();
}

// One vogctl run: its exit status and what it printed (stdout and stderr).
struct Vogctl {
  int status = -1;
  std::string out;
};

// How the simulated sonar's frames reach vogd.
enum class SonarLink { kFragments, kAris };

class Bench {
 public:
  explicit Bench(SonarLink link = SonarLink::kFragments) : link_(link), dir_("vog-hil") {}

  const fs::path& dir() const { return dir_.path(); }

  ::testing::AssertionResult startVehicle() {
    const fs::path run = dir() / "run";
    fs::create_directories(run);
    sonar_port_ = freeUdpPort();
    std::vector<std::string> args = {
        VOGSIM_EXECUTABLE, "vehicle",
        "--scene",         (vog::test::sourceDir() / "config/scenes/propeller.yaml").string(),
        "--seed",          "1",
        "--speedup",       std::to_string(kSpeedup),
        "--run-dir",       run.string(),
        "--backseat-port", "0",
        "--control",       (run / "control.sock").string(),
        "--no-stdin"};
    if (link_ == SonarLink::kAris) {
      // The mock ARIS: its command server on any port, its beacon to a port vogd listens on.
      args.insert(args.end(), {"--sonar-kind", "aris", "--aris-command-port", "0", "--aris-beacon-port",
                               std::to_string(sonar_port_)});
    } else {
      args.insert(args.end(), {"--sonar-port", std::to_string(sonar_port_)});
    }
    vogsim_ = std::make_unique<Subprocess>(args, std::vector<std::string>{}, dir() / "vogsim.log");
    if (!vogsim_->started()) return ::testing::AssertionFailure() << "vogsim did not start";
    const fs::path file = run / "endpoints.yaml";
    if (!waitUntil([&] { return fs::exists(file); }, 20.0))
      return ::testing::AssertionFailure() << "no endpoints file: " << vog::test::readTextFile(dir() / "vogsim.log");
    auto e = vog::vehicle::readEndpointsFile(file);
    if (!e) return ::testing::AssertionFailure() << e.error().message;
    endpoints_ = *e;
    return ::testing::AssertionSuccess();
  }

  // vogd's configuration for the vehicle's endpoints (what an integrator writes for a real vehicle);
  // aris_extra: more keys of devices.sonar.aris.
  void writeVogdConfig(const std::string& file = "vogd.yaml", const std::string& aris_extra = "") {
    const auto& e = endpoints_;
    std::ofstream(dir() / "operator.secret") << kSecret << "\n";
    fs::permissions(dir() / "operator.secret", fs::perms::owner_read | fs::perms::owner_write);
    std::ofstream y(dir() / file);
    y << "source: devices\n"
      << "mission:\n  max_submaps: 60\n"
      << "devices:\n  time_scale: " << kSpeedup << "\n"
      << "  dvl: {device: " << e.dvl_device << ", baud: " << e.dvl_baud
      << ", reconnect: {initial_delay_ms: 50, max_delay_ms: 500}}\n"
      << "  depth: {device: " << e.depth_device << ", baud: " << e.depth_baud
      << ", latitude_deg: " << e.depth_latitude_deg << ", units_code: " << e.depth_units_code
      << ", reconnect: {initial_delay_ms: 50, max_delay_ms: 500}}\n"
      << "  imu: {can_interface: \"\", unix_seqpacket: " << e.imu_unix_seqpacket << ", base_id: " << e.imu_base_id
      << ", reconnect: {initial_delay_ms: 50, max_delay_ms: 500}}\n"
      << sonarConfig(aris_extra) << "  backseat: {address: " << e.backseat_address << ", port: " << e.backseat_port
      << ", origin_latitude_deg: " << e.origin_latitude_deg << ", origin_longitude_deg: " << e.origin_longitude_deg
      << ", reconnect: {initial_delay_ms: 50, max_delay_ms: 500}}\n"
      // Scheduling jitter of a shared machine is multiplied by the speed-up.
      << "nav:\n  dvl_mount_yaw_deg: " << e.dvl_mount_yaw_deg << "\n  imu_max_gap_s: 0.5\n  imu_timeout_s: 0.5\n"
      << "api:\n  bind_address: 127.0.0.1\n  port: 0\n  secret_file: operator.secret\n";
  }

  ::testing::AssertionResult startVogd(const std::string& config = "vogd.yaml",
                                       const std::string& mission = "mission") {
    fs::remove(dir() / "port");
    vogd_ = std::make_unique<Subprocess>(
        std::vector<std::string>{VOGD_EXECUTABLE, "--config", (dir() / config).string(), "--mission-dir",
                                 (dir() / mission).string(), "--port-file", (dir() / "port").string()},
        std::vector<std::string>{}, dir() / "vogd.log");
    if (!vogd_->started()) return ::testing::AssertionFailure() << "vogd did not start";
    if (!waitUntil([&] { return fs::exists(dir() / "port"); }, 20.0))
      return ::testing::AssertionFailure() << "vogd wrote no port file: " << vogdLog();
    std::ifstream(dir() / "port") >> api_port_;
    return ::testing::AssertionSuccess();
  }

  // Any program run to its end: exit status and output.
  Vogctl run(const std::vector<std::string>& args, double timeout_s = 120.0) {
    static int n = 0;
    const fs::path log = dir() / ("run-" + std::to_string(++n) + ".out");
    Subprocess p(args, {}, log);
    Vogctl r;
    r.status = p.wait(timeout_s);
    r.out = vog::test::readTextFile(log);
    return r;
  }
  const vog::vehicle::VehicleEndpoints& endpoints() const { return endpoints_; }

  Vogctl vogctl(std::vector<std::string> args) {
    args.insert(args.begin(), VOGCTL_EXECUTABLE);
    args.insert(args.end(), {"--port", std::to_string(api_port_)});
    return run(args, 60.0);
  }

  // A number from `vogctl status --json` (-1 if it does not answer).
  long statusField(const std::string& key) {
    const Vogctl r = vogctl({"status", "--json"});
    std::smatch m;
    if (r.status != 0 || !std::regex_search(r.out, m, std::regex("\"" + key + "\":(-?[0-9]+)"))) return -1;
    return std::stol(m[1]);
  }
  std::string statusText(const std::string& key) {
    const Vogctl r = vogctl({"status", "--json"});
    std::smatch m;
    if (r.status != 0 || !std::regex_search(r.out, m, std::regex("\"" + key + "\":\"([^\"]*)\""))) return "";
    return m[1];
  }
  // A device's state in `vogctl status --json` ("" if it does not answer).
  std::string deviceState(const std::string& device) {
    const Vogctl r = vogctl({"status", "--json"});
    std::smatch m;
    if (r.status != 0 ||
        !std::regex_search(r.out, m, std::regex("\"device\":\"" + device + "\",\"state\":\"([a-z]+)\"")))
      return "";
    return m[1];
  }
  std::string control(const std::string& line) {
    return vog::test::controlRequest(dir() / "run" / "control.sock", line);
  }
  std::string vogdLog() const { return vog::test::readTextFile(dir() / "vogd.log"); }

  // The sonar's section: fragments on the port vogsim sends to, or the ARIS found by its beacon
  // (the serial number the endpoints name), its window matched to the simulated frame's 0.5-11 m
  // within the ARIS 1800's limits (a window from 0.7 m, 14.8 mm samples at most).
  std::string sonarConfig(const std::string& aris_extra) const {
    if (link_ == SonarLink::kFragments)
      return "  sonar: {bind_address: 127.0.0.1, port: " + std::to_string(sonar_port_) + "}\n";
    return "  sonar:\n    kind: aris\n    bind_address: 127.0.0.1\n    port: 0\n    aris:\n      beacon_port: " +
           std::to_string(sonar_port_) + "\n      serial_number: " + std::to_string(endpoints_.sonar_serial_number) +
           "\n      command_port: " + std::to_string(endpoints_.sonar_command_port) +
           "\n      window_start_m: 0.7\n      window_end_m: 11.0\n      samples_per_beam: 700\n"
           "      reconnect: {initial_delay_ms: 50, max_delay_ms: 500}\n" +
           aris_extra;
  }
  // A device's detail in `vogctl status --json` ("" if it does not answer).
  std::string deviceDetail(const std::string& device) {
    const Vogctl r = vogctl({"status", "--json"});
    std::smatch m;
    if (r.status != 0 ||
        !std::regex_search(r.out, m, std::regex("\"device\":\"" + device + "\"[^}]*\"detail\":\"([^\"]*)\"")))
      return "";
    return m[1];
  }

  Subprocess& vogd() { return *vogd_; }
  Subprocess& vogsim() { return *vogsim_; }

 private:
  SonarLink link_;
  vog::test::TempDir dir_;
  vog::vehicle::VehicleEndpoints endpoints_;
  std::uint16_t sonar_port_ = 0;
  std::uint16_t api_port_ = 0;
  std::unique_ptr<Subprocess> vogsim_, vogd_;
};

TEST(BenchMission, VogdOnMockDevicesMapsSurvivesFaultsAndResumesAfterKill9) {
  Bench b;
  ASSERT_TRUE(b.startVehicle());
  b.writeVogdConfig();
  ASSERT_TRUE(b.startVogd());

  // Navigation comes up from the raw devices (dead reckoning aligned to the vehicle's $BFNVG).
  ASSERT_TRUE(waitUntil([&] { return b.deviceState("navigation") == "ok"; }, 30.0))
      << b.vogctl({"status"}).out << b.vogdLog();

  // Without the secret the operator command is refused; with it the mission starts.
  const Vogctl refused = b.vogctl({"mission", "start", "--box", kBox});
  EXPECT_EQ(refused.status, 2) << refused.out;
  const Vogctl started =
      b.vogctl({"mission", "start", "--box", kBox, "--secret-file", (b.dir() / "operator.secret").string()});
  ASSERT_EQ(started.status, 0) << started.out;
  EXPECT_NE(started.out.find("exploring"), std::string::npos) << started.out;

  // Several submaps and a loop closure, the vehicle following vogd's waypoints over the backseat.
  const auto t_start = Clock::now();
  ASSERT_TRUE(waitUntil([&] { return b.statusField("n_submaps") >= 4 && b.statusField("n_closures") >= 1; }, 240.0))
      << b.vogctl({"status"}).out << b.vogdLog();
  ::testing::Test::RecordProperty(
      "wall_s_to_a_loop_closure",
      static_cast<int>(std::chrono::duration_cast<std::chrono::seconds>(Clock::now() - t_start).count()));
  const std::string vehicle = b.control("status");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(vehicle, m, std::regex("commands=([0-9]+)/([0-9]+)"))) << vehicle;
  EXPECT_GE(std::stoi(m[1]), 5) << vehicle;
  EXPECT_EQ(m[1], m[2]) << "the vehicle refused waypoints: " << vehicle;

  // The products, through the API: a snapshot and the cloud of the same map version (the map
  // changes with every closed submap and closure, so the pair is fetched until a snapshot before
  // and one after the cloud have the same version). The cloud is exactly the snapshot's occupied
  // voxels.
  octomap::OcTree tree(0.1);
  std::vector<Eigen::Vector3f> points;
  bool same_version = false;
  for (int attempt = 0; attempt < 20 && !same_version; ++attempt) {
    const Vogctl before = b.vogctl({"snapshot", "--out", (b.dir() / "map.bt").string(), "--json"});
    ASSERT_EQ(before.status, 0) << before.out;
    const Vogctl cloud = b.vogctl({"cloud", "--out", (b.dir() / "cloud.ply").string(), "--json"});
    ASSERT_EQ(cloud.status, 0) << cloud.out;
    const Vogctl after = b.vogctl({"snapshot", "--out", (b.dir() / "map-after.bt").string(), "--json"});
    ASSERT_EQ(after.status, 0) << after.out;
    std::smatch v0, v1;
    ASSERT_TRUE(std::regex_search(before.out, v0, std::regex("\"map_version\":([0-9]+)"))) << before.out;
    ASSERT_TRUE(std::regex_search(after.out, v1, std::regex("\"map_version\":([0-9]+)"))) << after.out;
    same_version = v0[1] == v1[1];
    ASSERT_TRUE(std::regex_search(cloud.out, m, std::regex("\"points\":([0-9]+)"))) << cloud.out;
    points = readBinaryPly(b.dir() / "cloud.ply");
    ASSERT_EQ(points.size(), std::stoul(m[1]));
  }
  ASSERT_TRUE(same_version) << "the map changed during every snapshot-cloud-snapshot sequence";
  ASSERT_TRUE(tree.readBinary((b.dir() / "map.bt").string()));
  EXPECT_GT(tree.getNumLeafNodes(), 10000u);
  EXPECT_GT(points.size(), 200u);
  std::size_t occupied_voxels = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it)
    if (tree.isNodeOccupied(*it)) occupied_voxels += std::size_t{1} << (3 * (tree.getTreeDepth() - it.getDepth()));
  std::size_t in_snapshot = 0;
  for (const Eigen::Vector3f& p : points) {
    const octomap::OcTreeNode* node = tree.search(p.x(), p.y(), p.z());
    if (node != nullptr && tree.isNodeOccupied(node)) ++in_snapshot;
  }
  EXPECT_EQ(in_snapshot, points.size());
  EXPECT_EQ(occupied_voxels, points.size());

  // Faults: garbage on the DVL line, then the IMU unplugged for 3 s (simulated). vogd keeps running,
  // counts the damage, reconnects, and mapping goes on.
  EXPECT_EQ(b.control("fault dvl garbage 2").rfind("ok", 0), 0u);
  EXPECT_EQ(b.control("unplug imu 3").rfind("ok", 0), 0u);
  ASSERT_TRUE(waitUntil([&] { return b.deviceState("imu") == "disconnected"; }, 10.0)) << b.vogctl({"status"}).out;
  ASSERT_TRUE(waitUntil([&] { return b.deviceState("imu") == "ok" && b.deviceState("navigation") == "ok"; }, 20.0))
      << b.vogctl({"status"}).out;
  const Vogctl after_faults = b.vogctl({"status", "--json"});
  ASSERT_TRUE(std::regex_search(after_faults.out, m, std::regex("\"device\":\"dvl\"[^}]*\"errors\":([0-9]+)")))
      << after_faults.out;
  EXPECT_GT(std::stol(m[1]), 0) << "the garbage was not seen";
  const long submaps_before_kill_wait = b.statusField("n_submaps");
  ASSERT_TRUE(waitUntil([&] { return b.statusField("n_submaps") > submaps_before_kill_wait; }, 60.0))
      << "mapping stopped after the faults: " << b.vogdLog();

  // kill -9 mid-mission, restart: every closed submap is back and the mission goes on.
  const long closed = b.statusField("n_submaps");
  ASSERT_GT(closed, 0);
  b.vogd().signal(SIGKILL);
  ASSERT_EQ(b.vogd().wait(5.0), 128 + SIGKILL);
  ASSERT_TRUE(b.startVogd());
  const long resumed = b.statusField("n_submaps");
  EXPECT_GE(resumed, closed) << b.vogdLog();
  EXPECT_EQ(b.statusText("mission_state"), "exploring");
  EXPECT_NE(b.vogdLog().find("resumed"), std::string::npos);
  ASSERT_TRUE(waitUntil([&] { return b.statusField("n_submaps") > resumed; }, 60.0))
      << "no new submap after the resume: " << b.vogdLog();

  b.vogd().signal(SIGTERM);
  EXPECT_EQ(b.vogd().wait(5.0), 0) << b.vogdLog();
  b.vogsim().signal(SIGTERM);
  EXPECT_EQ(b.vogsim().wait(5.0), 0);
}

// The bench mission with the sonar behind the ARIS live protocol (vogsim's mock ARIS): vogd finds
// the sonar by its beacon, sets it up over the command channel and maps its frame stream,
// acknowledging every part; lost, duplicated and reordered datagrams are survived; after a reboot of
// the sonar vogd reconnects and sends its settings again. Then the raw log decodes as an ARIS capture
// (`vogctl decode --format aris-stream`) and `vogd --replay` rebuilds every closed submap bit for bit.
TEST(BenchMission, VogdOnAMockArisFindsItMapsThroughLossAndARebootAndReplays) {
  Bench b(SonarLink::kAris);
  ASSERT_TRUE(b.startVehicle());
  b.writeVogdConfig();
  ASSERT_TRUE(b.startVogd());
  ASSERT_TRUE(waitUntil([&] { return b.deviceState("navigation") == "ok"; }, 30.0))
      << b.vogctl({"status"}).out << b.vogdLog();
  // Found by its beacon: model, serial number and software version; the settings sent are applied.
  ASSERT_TRUE(waitUntil(
      [&] {
        const std::string d = b.deviceDetail("sonar");
        return vog::test::contains(d, "ARIS 1800 serial " + std::to_string(b.endpoints().sonar_serial_number)) &&
               std::regex_search(d, std::regex("settings [0-9]+ applied"));
      },
      30.0))
      << b.vogctl({"status"}).out << b.vogdLog();
  EXPECT_EQ(b.deviceState("sonar"), "ok") << b.vogctl({"status"}).out;

  for (const char* fault : {"aris loss 0.03", "aris dup 0.02", "aris reorder 0.05"})
    EXPECT_EQ(b.control(fault).rfind("ok", 0), 0u) << fault;
  const Vogctl started =
      b.vogctl({"mission", "start", "--box", kBox, "--secret-file", (b.dir() / "operator.secret").string()});
  ASSERT_EQ(started.status, 0) << started.out;
  ASSERT_TRUE(waitUntil([&] { return b.statusField("n_submaps") >= 4 && b.statusField("n_closures") >= 1; }, 240.0))
      << b.vogctl({"status"}).out << b.vogdLog();

  // The sonar reboots: it forgets its settings; vogd sees the command channel drop, reconnects when
  // the sonar is back and sends the same settings (the same cookie), and mapping goes on.
  EXPECT_EQ(b.control("aris reboot 3").rfind("ok", 0), 0u);
  ASSERT_TRUE(waitUntil([&] { return b.deviceState("sonar") == "disconnected"; }, 10.0)) << b.vogctl({"status"}).out;
  ASSERT_TRUE(waitUntil(
      [&] {
        return b.deviceState("sonar") == "ok" &&
               std::regex_search(b.deviceDetail("sonar"), std::regex("settings [0-9]+ applied"));
      },
      30.0))
      << b.vogctl({"status"}).out << b.vogdLog();
  const long after_reboot = b.statusField("n_submaps");
  ASSERT_TRUE(waitUntil([&] { return b.statusField("n_submaps") > after_reboot; }, 90.0))
      << "no new submap after the sonar's reboot: " << b.vogctl({"status"}).out << b.vogdLog();

  b.vogd().signal(SIGTERM);
  ASSERT_EQ(b.vogd().wait(10.0), 0) << b.vogdLog();

  // A vogd configured for another model (an ARIS 3000 in its 128-beam mode): the beacon says 1800,
  // the sonar refuses the ping mode and keeps the settings of the run before, whose cookie the new
  // run does not take for its own. Both show as a degraded sonar, and vogd keeps running.
  b.writeVogdConfig("vogd-3000.yaml", "      model: \"3000\"\n      ping_mode: 9\n");
  ASSERT_TRUE(b.startVogd("vogd-3000.yaml", "mission-3000"));
  ASSERT_TRUE(waitUntil(
      [&] {
        const std::string d = b.deviceDetail("sonar");
        return b.deviceState("sonar") == "degraded" && vog::test::contains(d, "configured as an ARIS 3000") &&
               vog::test::contains(d, "the sonar has not taken the acoustic settings sent");
      },
      30.0))
      << b.vogctl({"status"}).out << b.vogdLog();
  b.vogd().signal(SIGTERM);
  ASSERT_EQ(b.vogd().wait(10.0), 0) << b.vogdLog();
  b.vogsim().signal(SIGTERM);
  EXPECT_EQ(b.vogsim().wait(5.0), 0);

  // The raw log is the capture: frames with the cookie sent, the commands of both connections, and
  // the duplicates the sonar was made to send.
  const Vogctl decoded =
      b.run({VOGCTL_EXECUTABLE, "decode", "--format", "aris-stream", (b.dir() / "mission").string(), "--json"});
  ASSERT_EQ(decoded.status, 0) << decoded.out;
  std::smatch m;
  ASSERT_TRUE(
      std::regex_search(decoded.out, m, std::regex("\"type\":\"summary\",\"datagrams\":([0-9]+),\"frames\":([0-9]+)")))
      << decoded.out.substr(0, 2000);
  EXPECT_GT(std::stol(m[2]), 100);
  EXPECT_TRUE(std::regex_search(decoded.out, m, std::regex("\"datagrams_duplicated\":([1-9][0-9]*)")));
  // One SET_ACOUSTICS per connection, the same settings with the same cookie.
  std::set<std::string> cookies;
  std::size_t acoustic = 0;
  const std::regex set_acoustics("\"command\":\"SET_ACOUSTICS\",\"cookie\":([0-9]+),");
  for (auto it = std::sregex_iterator(decoded.out.begin(), decoded.out.end(), set_acoustics);
       it != std::sregex_iterator(); ++it) {
    ++acoustic;
    cookies.insert((*it)[1]);
  }
  EXPECT_GE(acoustic, 2u);
  EXPECT_EQ(cookies.size(), 1u);

  // Replayed from the raw log: every submap vogd closed, bit for bit.
  const Vogctl replay = b.run({VOGD_EXECUTABLE, "--config", (b.dir() / "vogd.yaml").string(), "--replay",
                               (b.dir() / "mission").string(), "--out", (b.dir() / "replay").string()});
  ASSERT_EQ(replay.status, 0) << replay.out;
  std::size_t compared = 0;
  for (const auto& e : fs::directory_iterator(b.dir() / "mission" / "submaps")) {
    const fs::path again = b.dir() / "replay" / "submaps" / e.path().filename();
    ASSERT_TRUE(fs::exists(again)) << again << "\n" << replay.out;
    EXPECT_EQ(vog::test::readTextFile(e.path()), vog::test::readTextFile(again)) << e.path().filename();
    ++compared;
  }
  EXPECT_GE(compared, 5u);
}

}  // namespace
