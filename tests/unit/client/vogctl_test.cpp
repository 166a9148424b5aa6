// vogctl's API commands against a real ApiServer on a loopback port, with a small backend holding a
// real MergedMap (synthetic pier submaps), a cloud, and a mission that records the commands it gets.
// The commands run through runVogctl, i.e. the executable's own parsing, and their files and JSON are
// read back with independent readers (readers.hpp).
#include "vog/api/api_server.hpp"
#include "vog/client/top_view.hpp"
#include "vog/client/vogctl.hpp"

#include "map_fixtures.hpp"
#include "readers.hpp"
#include "test_support.hpp"

#include <asio.hpp>
#include <gtest/gtest.h>

#include <climits>
#include <future>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

namespace vog::client {
namespace {

using namespace std::chrono_literals;
using test::JsonObject;
using test::parseJsonLines;

constexpr const char* kSecret = "vogctl-test-secret-42";

// vogd behind the API, reduced to what the commands read and a mission that only records what
// reaches it (and refuses a start while exploring, like the real lifecycle).
class RecordingBackend final : public api::ApiBackend {
 public:
  RecordingBackend() {
    const auto built = map::test_fixtures::buildSubmaps(grid_, 3, 15, 7, 4.0);
    merged_ = map::MergedMap::create(grid_).value();
    for (std::size_t i = 0; i < built.size(); ++i) {
      const map::SubmapEntry e{static_cast<map::SubmapId>(i), built[i].grid, built[i].T_world_submap,
                               built[i].T_world_submap.inverse()};
      EXPECT_TRUE(merged_->add(e).ok());
      submaps_.push_back({static_cast<std::uint32_t>(i), e.T_world_submap, 15, static_cast<std::int64_t>(i) * 1000,
                          static_cast<std::int64_t>(i) * 1000 + 999, i == 0});
    }
    snapshot_ = merged_->snapshot();
    auto cloud = std::make_shared<api::ServedCloud>();
    cloud->map_version = snapshot_->version();
    for (int i = 0; i < 2500; ++i) {  // more than one chunk at 1000 points per chunk
      const float a = static_cast<float>(i) * 0.013f;
      cloud->points.push_back({Eigen::Vector3f(3.0f * std::cos(a), 3.0f * std::sin(a), -0.002f * static_cast<float>(i)),
                               Eigen::Vector3f(std::cos(a), std::sin(a), 0.0f)});
    }
    cloud_ = cloud;
  }

  api::StatusReport status() const override {
    std::lock_guard lock(mutex_);
    api::StatusReport s;
    s.stamp_ns = 42'000'000'000;
    s.mission_state = state_;
    s.T_world_vehicle = geometry::poseFromXyzRpy(1.0, -2.0, -3.0, 0.0, 0.0, 0.5);
    s.devices = {{"dvl", api::DeviceState::kOk, "", 41'000'000'000, 10, 0}};
    s.n_submaps = 3;
    s.map_version = snapshot_->version();
    return s;
  }
  std::shared_ptr<const map::MergedMap> mapSnapshot() const override { return snapshot_; }
  std::vector<api::SubmapInfo> submaps() const override { return submaps_; }
  // No pose graph and no grids: these clients never ask for them.
  std::shared_ptr<const api::GraphState> graph() const override { return nullptr; }
  std::shared_ptr<const map::LocalGrid> submapGrid(std::uint32_t) const override { return nullptr; }
  std::shared_ptr<const api::ServedCloud> cloud() const override {
    std::lock_guard lock(mutex_);
    return cloud_;
  }
  Result<api::MissionState> command(const api::MissionCommand& c) override {
    std::lock_guard lock(mutex_);
    using K = api::MissionCommand::Kind;
    if (c.kind == K::kStart && state_ == api::MissionState::kExploring) return Error{"start while exploring"};
    commands_.push_back(c);
    switch (c.kind) {
      case K::kSetBox: break;
      case K::kStart: state_ = api::MissionState::kExploring; break;
      case K::kPause: state_ = api::MissionState::kPaused; break;
      case K::kResume: state_ = api::MissionState::kExploring; break;
      case K::kAbort: state_ = api::MissionState::kAborted; break;
      case K::kReturnHome: state_ = api::MissionState::kReturning; break;
    }
    return state_;
  }
  // A YAML text with a quote, a backslash and a tab, which JSON must escape.
  std::string configText() const override { return "api:\n  port: 7400\nname: \"pier \\ 1\"\t# test\n"; }

  std::vector<api::MissionCommand> commands() const {
    std::lock_guard lock(mutex_);
    return commands_;
  }
  void setCloud(std::shared_ptr<const api::ServedCloud> cloud) {
    std::lock_guard lock(mutex_);
    cloud_ = std::move(cloud);
  }
  const map::MergedMap& map() const { return *snapshot_; }

 private:
  map::GridConfig grid_;
  std::unique_ptr<map::MergedMap> merged_;
  std::shared_ptr<const map::MergedMap> snapshot_;
  std::vector<api::SubmapInfo> submaps_;
  mutable std::mutex mutex_;
  std::shared_ptr<const api::ServedCloud> cloud_;       // guarded by mutex_
  api::MissionState state_ = api::MissionState::kIdle;  // guarded by mutex_
  std::vector<api::MissionCommand> commands_;           // guarded by mutex_
};

// The outcome of one vogctl invocation.
struct Outcome {
  int rc = -1;
  std::string out;
  std::string err;
};

class VogctlTest : public ::testing::Test {
 protected:
  void SetUp() override {
    api::ApiServerConfig config;
    config.dispatch.operator_secret = kSecret;
    config.dispatch.cloud_points_per_chunk = 1000;
    config.dispatch.map_blocks_per_chunk = 16;
    config.close_timeout = 200ms;
    server_ =
        api::ApiServer::create(io_, backend_, config, nullptr, std::make_unique<api::SeededNonceSource>(3)).value();
    port_ = server_->listen("127.0.0.1", 0).value();
    thread_ = std::thread([this] { io_.run(); });
    secret_file_ = (dir_.path() / "secret").string();
    std::ofstream(secret_file_) << kSecret << "\n";
    wrong_secret_file_ = (dir_.path() / "wrong").string();
    std::ofstream(wrong_secret_file_) << "not-the-secret\n";
  }
  void TearDown() override {
    server_->stop();
    asio::post(io_, [this] { io_.stop(); });
    thread_.join();
  }

  // Runs `vogctl ARGS --port <server>` as the executable would.
  Outcome vogctl(std::vector<std::string> args) const {
    args.push_back("--port");
    args.push_back(std::to_string(port_));
    args.push_back("--timeout-ms");
    args.push_back("5000");
    std::ostringstream out, err;
    const CommandIo io{out, err, false};
    Outcome r;
    r.rc = runVogctl(args, io);
    r.out = out.str();
    r.err = err.str();
    return r;
  }
  std::string path(const char* name) const { return (dir_.path() / name).string(); }

  RecordingBackend backend_;
  vog::test::TempDir dir_{"vogctl-test"};
  asio::io_context io_;
  std::unique_ptr<api::ApiServer> server_;
  std::uint16_t port_ = 0;
  std::thread thread_;
  std::string secret_file_;
  std::string wrong_secret_file_;
};

double number(const JsonObject& o, const std::string& key) {
  const auto it = o.find(key);
  if (it == o.end() || !std::holds_alternative<double>(it->second)) {
    ADD_FAILURE() << "no number " << key;
    return std::nan("");
  }
  return std::get<double>(it->second);
}
std::string text(const JsonObject& o, const std::string& key) {
  const auto it = o.find(key);
  if (it == o.end() || !std::holds_alternative<std::string>(it->second)) {
    ADD_FAILURE() << "no string " << key;
    return {};
  }
  return std::get<std::string>(it->second);
}

TEST_F(VogctlTest, CloudWritesABinaryPlyThatParsesBackToTheBackendsCloudExactly) {
  const Outcome r = vogctl({"cloud", "--out", path("c.ply"), "--json", "--progress"});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  const auto ply = test::decodePly(test::readFile(path("c.ply")));
  ASSERT_EQ(ply.error, "");
  EXPECT_EQ(ply.properties, (std::vector<std::string>{"x", "y", "z", "nx", "ny", "nz"}));
  const api::Cloud& want = backend_.cloud()->points;
  ASSERT_EQ(ply.vertices.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      ASSERT_EQ(ply.vertices[i][static_cast<std::size_t>(k)], want[i].p_world_m[k]) << i;
      ASSERT_EQ(ply.vertices[i][static_cast<std::size_t>(3 + k)], want[i].normal_world[k]) << i;
    }
  }
  const auto lines = parseJsonLines(r.out);
  ASSERT_TRUE(lines && lines->size() == 1) << r.out;
  EXPECT_EQ(text(lines->front(), "out"), path("c.ply"));
  EXPECT_EQ(number(lines->front(), "points"), 2500.0);
  EXPECT_EQ(lines->front().at("normals"), test::JsonValue(true));
  // --progress: progress on stderr even though it is not a terminal, ending at 100 %.
  EXPECT_NE(r.err.find("cloud: 2500 / 2500 points (100%)"), std::string::npos) << r.err;

  // A cloud without normals has x y z only.
  auto bare = std::make_shared<api::ServedCloud>();
  bare->points.push_back({Eigen::Vector3f(1.5f, -2.25f, 1e-30f), Eigen::Vector3f::Zero()});
  bare->points.push_back({Eigen::Vector3f(-0.0f, 3.0e7f, -7.125f), Eigen::Vector3f::Zero()});
  backend_.setCloud(bare);
  const Outcome r2 = vogctl({"cloud", "--out", path("bare.ply")});
  ASSERT_EQ(r2.rc, kExitOk) << r2.err;
  EXPECT_EQ(r2.err, "");  // no terminal, no --progress: no progress
  const auto ply2 = test::decodePly(test::readFile(path("bare.ply")));
  ASSERT_EQ(ply2.error, "");
  EXPECT_EQ(ply2.properties, (std::vector<std::string>{"x", "y", "z"}));
  ASSERT_EQ(ply2.vertices.size(), 2u);
  EXPECT_EQ(ply2.vertices[1], (std::vector<float>{-0.0f, 3.0e7f, -7.125f}));
  EXPECT_EQ(ply2.vertices[0][2], 1e-30f);
}

// What the server's map says of each (x, y) voxel column.
struct Column {
  int top_occupied_z = INT_MIN;
  bool free = false;
};

TEST_F(VogctlTest, TopViewPixelsHaveTheColourOfTheirColumnsHighestOccupiedVoxel) {
  const Outcome r = vogctl({"topview", "--out", path("top.png"), "--json"});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  const auto png = test::decodePng(test::readFile(path("top.png")));
  ASSERT_EQ(png.error, "");

  // The reference, from the server's own map: columns, extent, occupied height range.
  const map::MergedMap& m = backend_.map();
  const double res = m.resolution();
  std::map<std::pair<int, int>, Column> columns;
  int kx_min = INT_MAX, ky_max = INT_MIN, kz_min = INT_MAX, kz_max = INT_MIN;
  m.forEachKnown([&](const map::VoxelKey& k, const map::VoxelValue& v) {
    Column& c = columns[{k.x(), k.y()}];
    kx_min = std::min(kx_min, k.x());
    ky_max = std::max(ky_max, k.y());
    if (v.status == map::Occupancy::kOccupied) {
      c.top_occupied_z = std::max(c.top_occupied_z, k.z());
      kz_min = std::min(kz_min, k.z());
      kz_max = std::max(kz_max, k.z());
    } else {
      c.free = true;
    }
  });
  ASSERT_GT(kz_max, kz_min);
  const auto lines = parseJsonLines(r.out);
  ASSERT_TRUE(lines && lines->size() == 1) << r.out;
  EXPECT_EQ(number(lines->front(), "width_px"), static_cast<double>(png.width));
  EXPECT_EQ(number(lines->front(), "height_px"), static_cast<double>(png.height));
  EXPECT_NEAR(number(lines->front(), "z_min_m"), (kz_min + 0.5) * res, 1e-9);
  EXPECT_NEAR(number(lines->front(), "z_max_m"), (kz_max + 0.5) * res, 1e-9);

  // One pixel per voxel (the default): column (kx, ky) is pixel (kx - kx_min, ky_max - ky).
  std::size_t occupied = 0, free_only = 0;
  for (const auto& [key, c] : columns) {
    const auto px = static_cast<std::uint32_t>(key.first - kx_min);
    const auto py = static_cast<std::uint32_t>(ky_max - key.second);
    ASSERT_LT(px, png.width);
    ASSERT_LT(py, png.height);
    std::array<std::uint8_t, 3> want = kFreeColour;
    if (c.top_occupied_z != INT_MIN) {
      const double z = (c.top_occupied_z + 0.5) * res;
      want = heightColour((z - (kz_min + 0.5) * res) / ((kz_max - kz_min) * res));
      ++occupied;
    } else {
      ++free_only;
    }
    ASSERT_EQ(png.at(px, py), want) << "column " << key.first << "," << key.second;
  }
  EXPECT_GT(occupied, 20u);  // the pier's pilings seen from above
  EXPECT_GT(free_only, 50u);
  // Pixels of columns nobody knows are dark; the ramp's ends are distinct colours.
  std::size_t unknown = 0;
  for (std::uint32_t py = 0; py < png.height; ++py) {
    for (std::uint32_t px = 0; px < png.width; ++px) {
      if (columns.count({kx_min + static_cast<int>(px), ky_max - static_cast<int>(py)}) != 0) continue;
      ASSERT_EQ(png.at(px, py), kUnknownColour);
      ++unknown;
    }
  }
  EXPECT_EQ(unknown + columns.size(), static_cast<std::size_t>(png.width) * png.height);
  EXPECT_NE(heightColour(0.0), heightColour(1.0));
}

TEST_F(VogctlTest, TopViewAtLowerResolutionShowsTheHighestColumnInEachPixel) {
  // 4 px/m: about 2.6 x 2.6 columns per pixel; each pixel is the highest occupied voxel among the
  // columns whose centres it contains.
  const Outcome r = vogctl({"topview", "--out", path("coarse.png"), "--px-per-m", "4", "--json"});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  const auto png = test::decodePng(test::readFile(path("coarse.png")));
  ASSERT_EQ(png.error, "");
  const auto lines = parseJsonLines(r.out);
  ASSERT_TRUE(lines && lines->size() == 1) << r.out;
  const double x_min = number(lines->front(), "x_min_m"), y_max = number(lines->front(), "y_max_m");
  const double z_min = number(lines->front(), "z_min_m"), z_max = number(lines->front(), "z_max_m");
  const map::MergedMap& m = backend_.map();
  const double res = m.resolution();
  std::map<std::pair<int, int>, int> top;                                   // pixel -> highest occupied z key
  std::map<std::pair<int, int>, std::set<std::pair<int, int>>> columns_in;  // pixel -> occupied columns
  m.forEachKnown([&](const map::VoxelKey& k, const map::VoxelValue& v) {
    if (v.status != map::Occupancy::kOccupied) return;
    const int px = static_cast<int>(std::floor(((k.x() + 0.5) * res - x_min) * 4.0));
    const int py = static_cast<int>(std::floor((y_max - (k.y() + 0.5) * res) * 4.0));
    auto [it, inserted] = top.try_emplace({px, py}, k.z());
    if (!inserted) it->second = std::max(it->second, k.z());
    columns_in[{px, py}].insert({k.x(), k.y()});
  });
  ASSERT_GT(top.size(), 8u);
  // Some pixels gather several occupied columns: the highest must win there.
  EXPECT_GT(std::count_if(columns_in.begin(), columns_in.end(), [](const auto& p) { return p.second.size() > 1; }), 3);
  for (const auto& [p, kz] : top) {
    ASSERT_LT(static_cast<std::uint32_t>(p.first), png.width);
    ASSERT_LT(static_cast<std::uint32_t>(p.second), png.height);
    const auto want = heightColour(((kz + 0.5) * res - z_min) / (z_max - z_min));
    ASSERT_EQ(png.at(static_cast<std::uint32_t>(p.first), static_cast<std::uint32_t>(p.second)), want);
  }
}

TEST_F(VogctlTest, MissionCommandsNeedTheRightSecretAndReachTheBackend) {
  // No secret file: refused before connecting.
  Outcome r = vogctl({"mission", "start"});
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("--secret-file"), std::string::npos) << r.err;
  // Wrong secret: authentication fails, nothing reaches the mission.
  r = vogctl({"mission", "pause", "--secret-file", wrong_secret_file_});
  EXPECT_EQ(r.rc, kExitRefused);
  EXPECT_NE(r.err.find("authentication"), std::string::npos) << r.err;
  // A bad box is a usage error, named.
  r = vogctl({"mission", "start", "--box", "0,0,-5,10,nope,0", "--secret-file", secret_file_});
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("ymax 'nope'"), std::string::npos) << r.err;
  r = vogctl({"mission", "set-box", "--box", "0,0,0,-1,1,1", "--secret-file", secret_file_});
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("min_x_m"), std::string::npos) << r.err;
  EXPECT_TRUE(backend_.commands().empty());

  // Right secret: start with a box sets the box, then starts.
  r = vogctl({"mission", "start", "--box", "-1.5,-2,-6,8,9.25,-0.5", "--secret-file", secret_file_});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  EXPECT_NE(r.out.find("start: accepted, mission exploring"), std::string::npos) << r.out;
  auto commands = backend_.commands();
  ASSERT_EQ(commands.size(), 2u);
  EXPECT_EQ(commands[0].kind, api::MissionCommand::Kind::kSetBox);
  EXPECT_EQ(commands[0].box.min_world_m, Eigen::Vector3d(-1.5, -2, -6));
  EXPECT_EQ(commands[0].box.max_world_m, Eigen::Vector3d(8, 9.25, -0.5));
  EXPECT_EQ(commands[1].kind, api::MissionCommand::Kind::kStart);

  r = vogctl({"mission", "pause", "--json", "--secret-file", secret_file_});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  const auto lines = parseJsonLines(r.out);
  ASSERT_TRUE(lines && lines->size() == 1) << r.out;
  EXPECT_EQ(text(lines->front(), "command"), "pause");
  EXPECT_EQ(text(lines->front(), "mission_state"), "paused");
  for (const char* c : {"resume", "return-home", "abort"}) {
    EXPECT_EQ(vogctl({"mission", c, "--secret-file", secret_file_}).rc, kExitOk) << c;
  }
  commands = backend_.commands();
  ASSERT_EQ(commands.size(), 6u);
  EXPECT_EQ(commands[3].kind, api::MissionCommand::Kind::kResume);
  EXPECT_EQ(commands[4].kind, api::MissionCommand::Kind::kReturnHome);
  EXPECT_EQ(commands[5].kind, api::MissionCommand::Kind::kAbort);

  // The mission's refusal is printed with the server's reason, exit 1.
  ASSERT_EQ(vogctl({"mission", "start", "--secret-file", secret_file_}).rc, kExitOk);  // aborted -> exploring here
  r = vogctl({"mission", "start", "--secret-file", secret_file_});
  EXPECT_EQ(r.rc, kExitRefused);
  EXPECT_NE(r.err.find("start while exploring"), std::string::npos) << r.err;
}

TEST_F(VogctlTest, WaypointsCountThreePrintsThreePublishedWaypoints) {
  auto command = std::async(std::launch::async, [this] { return vogctl({"waypoints", "--count", "3", "--json"}); });
  // Publish until the command has its three (the first ones may go out before it subscribes).
  // The server numbers waypoints 1, 2, ... in publication order: waypoint i is at x = i.
  for (int i = 1; command.wait_for(20ms) != std::future_status::ready; ++i) {
    ASSERT_LT(i, 500) << "vogctl waypoints did not finish";
    api::Waypoint w;
    w.stamp_ns = i * 1'000'000'000LL;
    w.T_world_target = geometry::poseFromXyzRpy(i, -0.5 * i, -2.0, 0.0, 0.0, 0.25);
    w.speed_mps = 0.125 * i;
    server_->publishWaypoint(w);
  }
  const Outcome r = command.get();
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  const auto lines = parseJsonLines(r.out);
  ASSERT_TRUE(lines) << r.out;
  ASSERT_EQ(lines->size(), 3u) << r.out;
  double last_seq = 0.0;
  for (const JsonObject& o : *lines) {
    const double seq = number(o, "seq");
    EXPECT_GT(seq, last_seq);
    last_seq = seq;
    EXPECT_EQ(number(o, "stamp_ns"), seq * 1e9);
    EXPECT_NEAR(number(o, "x_m"), seq, 1e-9);
    EXPECT_NEAR(number(o, "y_m"), -0.5 * seq, 1e-9);
    EXPECT_NEAR(number(o, "z_m"), -2.0, 1e-9);
    EXPECT_NEAR(number(o, "yaw_rad"), 0.25, 1e-9);
    EXPECT_NEAR(number(o, "speed_mps"), 0.125 * seq, 1e-9);
    EXPECT_EQ(number(o, "dropped"), 0.0);
  }
}

TEST_F(VogctlTest, ReadCommandsPrintTheServersDataAsTextAndJson) {
  Outcome r = vogctl({"submaps", "--json"});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  auto lines = parseJsonLines(r.out);
  ASSERT_TRUE(lines) << r.out;
  const auto want = backend_.submaps();
  ASSERT_EQ(lines->size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i) {
    const JsonObject& o = (*lines)[i];
    EXPECT_EQ(number(o, "id"), want[i].id);
    EXPECT_EQ(o.at("closed"), test::JsonValue(want[i].closed));
    EXPECT_EQ(number(o, "n_scans"), 15.0);
    EXPECT_EQ(number(o, "last_stamp_ns"), static_cast<double>(want[i].last_stamp_ns));
    const Eigen::Vector3d t = want[i].T_world_submap.translation();
    EXPECT_NEAR(number(o, "x_m"), t.x(), 1e-8);
    EXPECT_NEAR(number(o, "y_m"), t.y(), 1e-8);
    EXPECT_NEAR(number(o, "z_m"), t.z(), 1e-8);
    EXPECT_NEAR(number(o, "yaw_rad"), geometry::yawOf(want[i].T_world_submap.linear()), 1e-8);
  }
  r = vogctl({"submaps"});
  ASSERT_EQ(r.rc, kExitOk);
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1 + static_cast<long>(want.size())) << r.out;

  r = vogctl({"config"});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  EXPECT_EQ(r.out, backend_.configText());
  r = vogctl({"config", "--json"});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  lines = parseJsonLines(r.out);
  ASSERT_TRUE(lines && lines->size() == 1) << r.out;
  EXPECT_EQ(text(lines->front(), "config"), backend_.configText());

  r = vogctl({"status", "--json"});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  lines = parseJsonLines(r.out);
  ASSERT_TRUE(lines && lines->size() == 2) << r.out;
  EXPECT_EQ(text(lines->front(), "mission_state"), "idle");
  EXPECT_EQ(number(lines->front(), "stamp_ns"), 42e9);
  EXPECT_NEAR(number(lines->front(), "yaw_rad"), 0.5, 1e-12);
  EXPECT_EQ(number(lines->front(), "map_version"), static_cast<double>(backend_.map().version()));
  EXPECT_EQ(text((*lines)[1], "device"), "dvl");

  // snapshot .ot: the file's known voxels are the server's.
  r = vogctl({"snapshot", "--out", path("m.ot"), "--json"});
  ASSERT_EQ(r.rc, kExitOk) << r.err;
  lines = parseJsonLines(r.out);
  ASSERT_TRUE(lines && lines->size() == 1) << r.out;
  EXPECT_EQ(number(lines->front(), "known_voxels"), static_cast<double>(backend_.map().knownVoxelCount()));
  EXPECT_GT(std::filesystem::file_size(path("m.ot")), 1000u);
}

TEST_F(VogctlTest, UsageAndConnectionErrorsExitWithTwoAndNameTheProblem) {
  Outcome r = vogctl({"topview", "--out", path("top.jpg")});
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find(".png"), std::string::npos) << r.err;
  r = vogctl({"topview", "--out", path("top.png"), "--px-per-m", "-3"});
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("px_per_m"), std::string::npos) << r.err;
  r = vogctl({"topview", "--out", path("top.png"), "--max-side-px", "20"});  // the map is ~100 voxels wide
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("lower px_per_m"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(path("top.png")));
  r = vogctl({"cloud", "--out", (dir_.path() / "no-such-dir" / "c.ply").string()});
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("no-such-dir"), std::string::npos) << r.err;
  r = vogctl({"cloud"});  // --out missing
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("--out"), std::string::npos) << r.err;
  r = vogctl({"waypoints", "--secret-file", path("absent")});
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("absent"), std::string::npos) << r.err;
  r = vogctl({"mission", "set-box", "--secret-file", secret_file_});  // --box missing
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("--box"), std::string::npos) << r.err;

  // Nothing listens on the server's port once it is stopped (stop() closes the listener on the
  // server's thread, soon after it returns; a connection accepted just before is reset).
  server_->stop();
  for (int i = 0; i < 200; ++i) {
    r = vogctl({"status"});
    if (r.err.find("cannot connect") != std::string::npos) break;
    std::this_thread::sleep_for(10ms);
  }
  EXPECT_EQ(r.rc, kExitUsage);
  EXPECT_NE(r.err.find("cannot connect"), std::string::npos) << r.err;
  // --help is not an error.
  std::ostringstream out, err;
  EXPECT_EQ(runVogctl({"mission", "start", "--help"}, CommandIo{out, err, false}), kExitOk);
  EXPECT_NE(out.str().find("--box"), std::string::npos);
}

}  // namespace
}  // namespace vog::client
