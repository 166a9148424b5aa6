// vogd's daemon in-process against the built-in simulator, through the real API: a mission runs to
// completion with its submaps durable, operator commands need the secret, a restart resumes every
// closed submap, a replay of the raw log rebuilds the same submaps bit for bit, and stop is prompt.
#include "vog/app/daemon.hpp"
#include "vog/app/replay.hpp"
#include "vog/client/api_client.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <future>
#include <thread>

namespace vog::app {
namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kSecret = "correct horse battery staple";

VogdConfig simConfig(const test::TempDir& dir, int max_submaps) {
  const std::filesystem::path secret = dir.path() / "secret";
  std::ofstream(secret) << kSecret << "\n";
  std::filesystem::permissions(secret, std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
  const std::string text =
      "source: sim\n"
      "sim:\n  scene: scenes/pilings.yaml\n  seed: 3\n  speedup: 0\n"
      "mission:\n  box_min_m: [-6, -4, -4]\n  box_max_m: [6, 4, 0]\n"
      "  start_on_launch: true\n  max_submaps: " +
      std::to_string(max_submaps) +
      "\n"
      "api:\n  port: 0\n  secret_file: " +
      secret.string() + "\n";
  return parseVogdConfig(text, "test.yaml", test::sourceDir() / "config").value();
}

// Runs a daemon on its own thread; stop() asks it to stop and measures how long run() takes to return.
struct RunningDaemon {
  explicit RunningDaemon(std::unique_ptr<Daemon> d) : daemon(std::move(d)) {
    thread = std::thread([this] { result = daemon->run(); });
  }
  ~RunningDaemon() { stop(); }
  double stop() {
    if (!thread.joinable()) return 0.0;
    const auto t0 = Clock::now();
    daemon->requestStop();
    thread.join();
    return std::chrono::duration<double>(Clock::now() - t0).count();
  }
  std::uint16_t port(const std::filesystem::path& port_file) const {
    for (int i = 0; i < 500; ++i) {
      std::ifstream in(port_file);
      int p = 0;
      if (in >> p && p > 0) return static_cast<std::uint16_t>(p);
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return 0;
  }
  std::unique_ptr<Daemon> daemon;
  std::thread thread;
  Status result;
};

api::StatusReport waitFor(client::ApiClient& c, const std::function<bool(const api::StatusReport&)>& done,
                          double timeout_s) {
  const auto t0 = Clock::now();
  api::StatusReport s;
  while (std::chrono::duration<double>(Clock::now() - t0).count() < timeout_s) {
    auto r = c.status();
    EXPECT_TRUE(r.ok());
    if (!r) break;
    s = *r;
    if (done(s)) return s;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return s;
}

std::size_t countFiles(const std::filesystem::path& dir) {
  std::size_t n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) n += e.is_regular_file() ? 1 : 0;
  return n;
}

TEST(Daemon, SimulatedMissionRunsResumesAndReplays) {
  test::TempDir dir("vogd-test");
  const VogdConfig config = simConfig(dir, 4);
  DaemonOptions options;
  options.mission_dir = dir.path() / "mission";
  options.port_file = dir.path() / "port";

  std::size_t submaps_before_stop = 0;
  {
    RunningDaemon run(Daemon::create(config, options).value());
    const std::uint16_t port = run.port(*options.port_file);
    ASSERT_NE(port, 0);
    auto c = client::ApiClient::connect("127.0.0.1", port).value();
    const api::StatusReport done = waitFor(
        *c,
        [](const api::StatusReport& s) {
          return s.mission_state == api::MissionState::kComplete || s.mission_state == api::MissionState::kAborted;
        },
        120.0);
    ASSERT_EQ(done.mission_state, api::MissionState::kComplete) << "the budget of 4 submaps ends the mission at home";
    EXPECT_GE(done.n_submaps, 4u);
    ASSERT_EQ(done.devices.size(), 2u);
    EXPECT_EQ(done.devices[0].state, api::DeviceState::kOk) << done.devices[0].detail;  // no collision
    EXPECT_EQ(done.devices[1].name, "storage");
    EXPECT_EQ(done.devices[1].state, api::DeviceState::kOk) << done.devices[1].detail;
    // The map is served: a snapshot with occupied voxels and a cloud of them.
    auto cloud = c->cloud();
    ASSERT_TRUE(cloud.ok()) << cloud.error().message;
    EXPECT_GT(cloud->size(), 1000u);
    // The submap list and the status agree once the mapping thread has worked through the scans taken
    // before the end (the last submap can close just after the mission reports complete).
    std::size_t listed = 0;
    const api::StatusReport settled = waitFor(
        *c,
        [&](const api::StatusReport& s) {
          auto submaps = c->submaps();
          EXPECT_TRUE(submaps.ok());
          listed = submaps.ok() ? submaps->size() : 0;
          return listed == s.n_submaps;
        },
        30.0);
    EXPECT_EQ(listed, settled.n_submaps);
    EXPECT_GE(settled.n_submaps, done.n_submaps);

    // Commands: refused without the operator role, refused by the mission when they do not apply.
    api::MissionCommand pause;
    pause.kind = api::MissionCommand::Kind::kPause;
    EXPECT_FALSE(c->command(pause).ok());
    ASSERT_EQ(c->authenticate(kSecret).value(), api::Role::kOperator);
    auto refused = c->command(pause);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().message.find("pause refused while complete"), std::string::npos)
        << refused.error().message;
    api::MissionCommand start;
    start.kind = api::MissionCommand::Kind::kStart;
    EXPECT_EQ(c->command(start).value(), api::MissionState::kExploring);  // a new exploration, budget spent
    waitFor(
        *c, [](const api::StatusReport& s) { return s.mission_state == api::MissionState::kComplete; }, 60.0);
    submaps_before_stop = c->status().value().n_submaps;
    const double stop_s = run.stop();
    EXPECT_TRUE(run.result.ok()) << run.result.error().message;
    EXPECT_LT(stop_s, 2.0);
  }
  // Every submap reported before the stop is on disk, plus the active one closed at shutdown.
  const std::size_t stored = countFiles(*options.mission_dir / "submaps");
  EXPECT_GE(stored, submaps_before_stop);

  // Restart on the same folder: every stored submap is back before anything new is mapped.
  {
    auto d = Daemon::create(config, options).value();
    EXPECT_EQ(d->submaps().size(), stored);
    EXPECT_EQ(d->status().mission_state, api::MissionState::kComplete);
  }

  // Replay of the raw log: the same submaps, byte for byte.
  const std::filesystem::path out = dir.path() / "replay";
  auto stats = replayMission(config, *options.mission_dir, out);
  ASSERT_TRUE(stats.ok()) << stats.error().message;
  EXPECT_EQ(stats->submaps, stored);
  EXPECT_EQ(stats->rejected_scans, 0u);
  for (const auto& e : std::filesystem::directory_iterator(*options.mission_dir / "submaps"))
    EXPECT_EQ(test::readFile(e.path()), test::readFile(out / "submaps" / e.path().filename())) << e.path().filename();
  EXPECT_TRUE(std::filesystem::exists(out / "map.bt"));
  // A second replay into the same folder is refused, not mixed in.
  EXPECT_FALSE(replayMission(config, *options.mission_dir, out).ok());
}

// A vehicle that hands over `n` scans of a wall as fast as the daemon takes them, on its own thread,
// then holds still; it counts the scans the daemon accepted.
class ScriptedVehicle final : public VehicleSource {
 public:
  explicit ScriptedVehicle(int n) : n_(n) {}
  ~ScriptedVehicle() override { stop(); }
  Status start(SourceSink& sink) override {
    thread_ = std::thread([this, &sink] {
      OdometrySample o;
      o.T_odom_vehicle = geometry::poseFromXyzRpy(0, 0, -2, 0, 0, 0);
      sink.onOdometry(o);
      for (int i = 0; i < n_ && !stopping_; ++i) {
        slam::ScanInput in;
        in.scan.stamp_ns = (i + 1) * 100'000'000LL;
        in.T_world_vehicle_odom = geometry::poseFromXyzRpy(0, -3.0 + 0.01 * i, -2, 0, 0, 0);  // inside the box
        in.z_roll_pitch = Eigen::Vector3d(-2, 0, 0);
        in.scan.range_m.assign(96, 4.0f);
        if (!sink.onScan(in, std::nullopt)) break;
        ++accepted_;
      }
      handed_over_.set_value();
    });
    return {};
  }
  void stop() override {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
  }
  Status setWaypoints(std::vector<SourceWaypoint>) override { return {}; }
  bool idle() const override { return false; }  // never arrives: the planner waits
  std::vector<api::DeviceHealth> health() const override { return {}; }
  std::uint64_t heartbeat() const override { return 0; }
  Status failure() const override { return {}; }
  std::optional<SourceObstruction> takeObstruction() override { return std::nullopt; }

  std::future<void> handedOver() { return handed_over_.get_future(); }
  int accepted() const { return accepted_; }

 private:
  const int n_;
  std::thread thread_;
  std::atomic<bool> stopping_{false};
  std::atomic<int> accepted_{0};  // written by the vehicle's thread
  std::promise<void> handed_over_;
};

// A stop while mapping is behind (the queue full) maps every scan the source handed over before the
// active submap is closed, and a replay of the log maps the same scans into the same submaps.
TEST(Daemon, AStopMapsEveryScanTheSourceHandedOver) {
  test::TempDir dir("vogd-test");
  const VogdConfig config = simConfig(dir, 1000);
  DaemonOptions options;
  options.mission_dir = dir.path() / "mission";
  constexpr int kScans = 600;  // more than the queue holds
  ScriptedVehicle* vehicle = nullptr;
  options.make_source = [&]() -> Result<std::unique_ptr<VehicleSource>> {
    auto v = std::make_unique<ScriptedVehicle>(kScans);
    vehicle = v.get();
    return std::unique_ptr<VehicleSource>(std::move(v));
  };
  {
    RunningDaemon run(Daemon::create(config, options).value());
    ASSERT_NE(vehicle, nullptr);
    ASSERT_EQ(vehicle->handedOver().wait_for(std::chrono::seconds(120)), std::future_status::ready);
    run.stop();  // at once: the queue still holds most of the scans
    ASSERT_TRUE(run.result.ok()) << run.result.error().message;
    EXPECT_EQ(vehicle->accepted(), kScans);
  }
  std::size_t mapped = 0;
  {
    auto d = Daemon::create(config, options);  // resumed, not run
    ASSERT_TRUE(d.ok()) << d.error().message;
    for (const api::SubmapInfo& s : (*d)->submaps()) mapped += s.n_scans;
  }
  // Every scan is in the log, mapped or (those taken before the mission started) only recorded.
  auto stats = replayMission(config, *options.mission_dir, dir.path() / "replay");
  ASSERT_TRUE(stats.ok()) << stats.error().message;
  EXPECT_EQ(stats->scans + stats->not_mapped, static_cast<std::uint64_t>(kScans));
  EXPECT_EQ(stats->scans, mapped);
  EXPECT_GT(mapped, 0u);
  for (const auto& e : std::filesystem::directory_iterator(*options.mission_dir / "submaps"))
    EXPECT_EQ(test::readFile(e.path()), test::readFile(dir.path() / "replay" / "submaps" / e.path().filename()))
        << e.path().filename();
}

TEST(Daemon, BadSetupIsRefusedWithAReason) {
  test::TempDir dir("vogd-test");
  VogdConfig config = simConfig(dir, 4);
  config.sim.scene = dir.path() / "missing.yaml";
  DaemonOptions options;
  options.mission_dir = dir.path() / "mission";
  auto d = Daemon::create(config, options);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().message.find("sim.scene"), std::string::npos) << d.error().message;

  config = simConfig(dir, 4);
  const std::filesystem::path weak = dir.path() / "weak";
  std::ofstream(weak) << "short\n";
  config.api.secret_file = weak;
  d = Daemon::create(config, options);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().message.find("fewer than 16 bytes"), std::string::npos) << d.error().message;

  // A mission folder that is a file cannot be opened.
  config = simConfig(dir, 4);
  std::ofstream(dir.path() / "file") << "x";
  options.mission_dir = dir.path() / "file";
  d = Daemon::create(config, options);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.error().message.find("mission directory"), std::string::npos) << d.error().message;
}

}  // namespace
}  // namespace vog::app
