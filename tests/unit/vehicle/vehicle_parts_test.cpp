// Parts of the simulated vehicle that need no running simulation: control command parsing, the
// endpoints file and the configuration checks.

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>

#include "test_support.hpp"
#include "vog/vehicle/control.hpp"
#include "vog/vehicle/endpoints.hpp"
#include "vog/vehicle/sim_vehicle.hpp"

namespace vog::vehicle {
namespace {

TEST(VehicleControlTest, ParsesEveryDeviceFaultAndUnplug) {
  auto f = parseControlCommand("  fault depth badcrc 2.5\r\n");
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->kind, ControlCommand::Kind::kFault);
  EXPECT_EQ(f->device, Device::kDepth);
  EXPECT_EQ(f->fault, mock::Fault::kBadChecksum);
  EXPECT_DOUBLE_EQ(f->seconds, 2.5);
  for (const char* d : {"dvl", "depth", "imu", "sonar", "backseat"}) {
    for (const char* k : {"garbage", "truncate", "badcrc", "dropout"}) {
      auto c = parseControlCommand(std::string("fault ") + d + " " + k + " 1");
      ASSERT_TRUE(c.ok()) << d << " " << k;
      EXPECT_STREQ(toString(c->device), d);
      EXPECT_STREQ(faultName(c->fault), k);
    }
    auto u = parseControlCommand(std::string("unplug ") + d + " 3");
    ASSERT_TRUE(u.ok());
    EXPECT_EQ(u->kind, ControlCommand::Kind::kUnplug);
    EXPECT_STREQ(toString(u->device), d);
  }
  EXPECT_EQ(parseControlCommand("status")->kind, ControlCommand::Kind::kStatus);
}

TEST(VehicleControlTest, ParsesArisCommands) {
  for (const auto& [word, action] : {std::pair{"loss", ArisAction::kLoss}, std::pair{"dup", ArisAction::kDuplicate},
                                     std::pair{"reorder", ArisAction::kReorder}}) {
    auto c = parseControlCommand(std::string("aris ") + word + " 0.05");
    ASSERT_TRUE(c.ok()) << word << ": " << c.error().message;
    EXPECT_EQ(c->kind, ControlCommand::Kind::kAris);
    EXPECT_EQ(c->aris_action, action);
    EXPECT_DOUBLE_EQ(c->probability, 0.05);
    EXPECT_STREQ(arisActionName(c->aris_action), word);
  }
  EXPECT_DOUBLE_EQ(parseControlCommand("aris loss 0")->probability, 0.0);
  EXPECT_DOUBLE_EQ(parseControlCommand("aris dup 1")->probability, 1.0);
  auto r = parseControlCommand("aris reboot 2.5");
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->aris_action, ArisAction::kReboot);
  EXPECT_DOUBLE_EQ(r->seconds, 2.5);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"aris", "usage: aris"},        {"aris loss", "usage: aris"},    {"aris jam 0.1", "unknown aris command 'jam'"},
      {"aris loss 1.5", "got '1.5'"}, {"aris dup -0.1", "got '-0.1'"}, {"aris reorder nan", "got 'nan'"},
      {"aris reboot 0", "got '0'"},
  };
  for (const auto& [line, expected] : bad) {
    auto c = parseControlCommand(line);
    ASSERT_FALSE(c.ok()) << line;
    EXPECT_NE(c.error().message.find(expected), std::string::npos) << line << " -> " << c.error().message;
  }
}

TEST(VehicleControlTest, BadLinesNameWhatIsWrong) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"", "empty command"},
      {"reboot", "unknown command 'reboot'"},
      {"fault gps garbage 1", "unknown device 'gps'"},
      {"fault dvl noise 1", "unknown fault 'noise'"},
      {"fault dvl garbage", "usage: fault"},
      {"unplug imu 0", "got '0'"},
      {"unplug imu -1", "got '-1'"},
      {"unplug imu 1e9", "got '1e9'"},
      {"unplug imu nan", "got 'nan'"},
      {"unplug imu 2s", "got '2s'"},
      {"status now", "no arguments"},
  };
  for (const auto& [line, expected] : cases) {
    auto c = parseControlCommand(line);
    ASSERT_FALSE(c.ok()) << line;
    EXPECT_NE(c.error().message.find(expected), std::string::npos) << line << " -> " << c.error().message;
  }
}

TEST(EndpointsFileTest, RoundTripsEveryFieldAndLeavesNoTemporaryFile) {
  test::TempDir dir("vog-endpoints");
  VehicleEndpoints e;
  e.scene_file = "/x/pilings.yaml";
  e.scene_name = "pilings";
  e.seed = 77;
  e.pid = 1234;
  e.speedup = 12.5;
  e.steady_ns_at_sim_zero = 987'654'321'012;
  e.epoch_unix_ns = 1'767'225'600'000'000'000;
  e.origin_latitude_deg = 42.123456789;
  e.origin_longitude_deg = -70.987654321;
  e.start_xyz_world = Eigen::Vector3d(-5.0, 0.25, -1.5);
  e.start_yaw_deg = 30.0;
  e.dvl_device = "/tmp/run/dvl";
  e.depth_device = "/tmp/run/depth";
  e.depth_units_code = 8;
  e.depth_reading_is_absolute = false;
  e.imu_unix_seqpacket = "/tmp/run/imu.sock";
  e.sonar_port = 52102;
  e.backseat_port = 29500;
  e.control_socket = "/tmp/run/control";
  const auto file = dir.path() / "endpoints.yaml";
  ASSERT_TRUE(writeEndpointsFile(file, e).ok());
  int entries = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) ++entries;
  EXPECT_EQ(entries, 1);  // the temporary file was renamed, not left behind
  auto r = readEndpointsFile(file);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->scene_file, e.scene_file);
  EXPECT_EQ(r->scene_name, e.scene_name);
  EXPECT_EQ(r->seed, e.seed);
  EXPECT_EQ(r->pid, e.pid);
  EXPECT_DOUBLE_EQ(r->speedup, e.speedup);
  EXPECT_EQ(r->steady_ns_at_sim_zero, e.steady_ns_at_sim_zero);
  EXPECT_EQ(r->epoch_unix_ns, e.epoch_unix_ns);
  EXPECT_DOUBLE_EQ(r->origin_latitude_deg, e.origin_latitude_deg);
  EXPECT_DOUBLE_EQ(r->origin_longitude_deg, e.origin_longitude_deg);
  EXPECT_EQ(r->start_xyz_world, e.start_xyz_world);
  EXPECT_DOUBLE_EQ(r->start_yaw_deg, e.start_yaw_deg);
  EXPECT_EQ(r->dvl_device, e.dvl_device);
  EXPECT_EQ(r->depth_device, e.depth_device);
  EXPECT_EQ(r->depth_units_code, 8);
  EXPECT_FALSE(r->depth_reading_is_absolute);
  EXPECT_EQ(r->imu_unix_seqpacket, e.imu_unix_seqpacket);
  EXPECT_EQ(r->imu_base_id, 0x180u);
  EXPECT_EQ(r->sonar_kind, SonarKind::kFragments);
  EXPECT_EQ(r->sonar_port, 52102);
  EXPECT_EQ(r->backseat_port, 29500);
  EXPECT_EQ(r->control_socket, e.control_socket);
  EXPECT_EQ(simStampFromSteady(*r, e.steady_ns_at_sim_zero + 2'000'000'000), 25'000'000'000);
}

TEST(EndpointsFileTest, ArisSonarRoundTripsAndOldFilesReadAsFragments) {
  test::TempDir dir("vog-endpoints");
  const auto file = dir.path() / "endpoints.yaml";
  VehicleEndpoints e;
  e.sonar_kind = SonarKind::kAris;
  e.sonar_command_port = 56888;
  e.sonar_beacon_port = 56124;
  e.sonar_serial_number = 1234;
  ASSERT_TRUE(writeEndpointsFile(file, e).ok());
  std::string text;
  {
    std::ifstream in(file);
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  EXPECT_NE(text.find("kind: aris"), std::string::npos) << text;
  auto r = readEndpointsFile(file);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->sonar_kind, SonarKind::kAris);
  EXPECT_EQ(r->sonar_address, "127.0.0.1");
  EXPECT_EQ(r->sonar_command_port, 56888);
  EXPECT_EQ(r->sonar_beacon_port, 56124);
  EXPECT_EQ(r->sonar_serial_number, 1234u);
  {
    std::string t = text;
    t.replace(t.find("  serial_number: 1234\n"), 22, "");
    std::ofstream(file) << t;
    auto missing = readEndpointsFile(file);
    ASSERT_FALSE(missing.ok());
    EXPECT_NE(missing.error().message.find("missing key sonar.serial_number"), std::string::npos)
        << missing.error().message;
  }
  {
    std::string t = text;
    t.replace(t.find("kind: aris"), 10, "kind: didson");
    std::ofstream(file) << t;
    auto unknown = readEndpointsFile(file);
    ASSERT_FALSE(unknown.ok());
    EXPECT_NE(unknown.error().message.find("sonar kind 'didson'"), std::string::npos) << unknown.error().message;
  }

  // A file written before sonar.kind existed: {address, port}.
  VehicleEndpoints old;
  old.sonar_port = 52102;
  ASSERT_TRUE(writeEndpointsFile(file, old).ok());
  {
    std::ifstream in(file);
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  text.replace(text.find("  kind: fragments\n"), 18, "");
  std::ofstream(file) << text;
  r = readEndpointsFile(file);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->sonar_kind, SonarKind::kFragments);
  EXPECT_EQ(r->sonar_port, 52102);
}

TEST(EndpointsFileTest, MissingKeysAndWrongVersionAreNamed) {
  test::TempDir dir("vog-endpoints");
  const auto file = dir.path() / "endpoints.yaml";
  ASSERT_TRUE(writeEndpointsFile(file, VehicleEndpoints{}).ok());
  std::ifstream in(file);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  {
    std::string t = text;
    t.replace(t.find("  port: 0\n", t.find("backseat:")), 10, "");
    std::ofstream(file) << t;
    auto r = readEndpointsFile(file);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("missing key backseat.port"), std::string::npos) << r.error().message;
  }
  {
    std::string t = text;
    t.replace(t.find("format_version: 1"), 17, "format_version: 2");
    std::ofstream(file) << t;
    auto r = readEndpointsFile(file);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("format_version 2"), std::string::npos) << r.error().message;
  }
  EXPECT_FALSE(readEndpointsFile(dir.path() / "absent.yaml").ok());
}

TEST(SimVehicleConfigTest, BadValuesNameTheKey) {
  test::TempDir dir("vog-vehicle-config");
  SimVehicleConfig c;
  c.run_dir = dir.path();
  EXPECT_TRUE(c.validate().ok()) << c.validate().error().message;
  const std::vector<std::pair<std::function<void(SimVehicleConfig&)>, std::string>> cases = {
      {[](SimVehicleConfig& x) { x.speedup = 0.0; }, "vehicle.speedup"},
      {[](SimVehicleConfig& x) { x.speedup = 5000.0; }, "vehicle.speedup"},
      {[](SimVehicleConfig& x) { x.duration_s = -1.0; }, "vehicle.duration_s"},
      {[](SimVehicleConfig& x) { x.run_dir = "/nonexistent/run"; }, "vehicle.run_dir"},
      {[](SimVehicleConfig& x) { x.nav_sentence_rate_hz = 0.0; }, "vehicle.nav_sentence_rate_hz"},
      {[](SimVehicleConfig& x) { x.operating_margin_m = -2.0; }, "vehicle.operating_margin_m"},
      {[](SimVehicleConfig& x) { x.origin_latitude_deg = 91.0; }, "latitude_deg"},
      {[](SimVehicleConfig& x) { x.lockstep.sonar_rate_hz = -1.0; }, "sonar_rate_hz"},
  };
  for (const auto& [mutate, key] : cases) {
    SimVehicleConfig bad = c;
    mutate(bad);
    const Status st = bad.validate();
    ASSERT_FALSE(st.ok()) << key;
    EXPECT_NE(st.error().message.find(key), std::string::npos) << st.error().message;
  }
}

}  // namespace
}  // namespace vog::vehicle
