// The controller in closed loop, in lockstep simulated time: the simulator moves the vehicle and
// takes its sonar scans, the mapping pipeline builds submaps at the vehicle's odometry, the merged
// map follows them, and the controller steers on that map from the odometry estimate, as vogd and
// `vog-bench mission` run it. A short mission on the tank ends on its submap budget at home, every
// waypoint it sent lies in the exploration box, and a second run with the same seed is the same
// mission bit for bit. A whole tank survey with loop closures (the thesis's real-world experiment,
// `vog-bench mission --scene config/scenes/tank.yaml --mode vog-lc --seed 1`) completes and comes
// home.
#include "vog/explore/exploration_controller.hpp"
#include "vog/map/merged_map.hpp"
#include "vog/sim/lockstep.hpp"
#include "vog/sim/scene.hpp"
#include "vog/slam/mapping_pipeline.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <deque>

namespace vog::explore {
namespace {

using geometry::Pose3;

struct Scans final : sim::SimulationSink {
  void scan(std::uint32_t /*index*/, const sim::SonarPing& ping, const Pose3& /*T_true*/,
            const Pose3& T_odom) override {
    slam::ScanInput in;
    in.T_world_vehicle_odom = T_odom;
    const Eigen::Vector3d rpy = geometry::rpyFromRotation(T_odom.linear());
    in.z_roll_pitch = Eigen::Vector3d(T_odom.translation().z(), rpy.x(), rpy.y());
    in.scan = ping.scan;
    pending.push_back(std::move(in));
  }
  void truth(const sim::VehicleState& /*state*/, const Pose3& T_odom) override { T_odom_now = T_odom; }
  std::deque<slam::ScanInput> pending;
  Pose3 T_odom_now = Pose3::Identity();
};

struct Mission {
  std::vector<plan::Waypoint> sent;  // every waypoint the controller sent, map frame
  Ending ending = Ending::kNone;
  std::string summary;
  std::size_t n_submaps = 0;
  double seconds = 0.0;
  Pose3 T_true_end = Pose3::Identity();
};

// `loop_closures`: as vog-bench mission's vog-lc mode (its odometry noise, degeneracy-aware closures);
// without, raw odometry at the thesis's rates.
Mission runMission(std::uint64_t seed, int budget, bool loop_closures = false) {
  Mission m;
  auto scene = sim::loadScene(test::sourceDir() / "config/scenes/tank.yaml").value();
  auto world = sim::World::create(scene).value();
  sim::LockstepConfig sc;
  sc.seed = seed;
  sc.frame_every = 0;
  if (loop_closures) {
    sc.odometry.profile = sim::OdometryNoiseProfile::kRandomWalk;
    sc.odometry.sigma2_x_m2ps *= 0.25;
    sc.odometry.sigma2_y_m2ps *= 0.25;
    sc.odometry.sigma2_yaw_rad2ps *= 0.25;
    sc.odometry.world_frame_xy_noise = true;
  }
  auto simulation = sim::LockstepSimulation::create(*world, sc).value();
  slam::MappingPipelineConfig mc;
  mc.loop_closures = loop_closures;
  mc.loop_closer.mode = slam::LoopClosureMode::kDegenerate;
  auto pipeline = slam::MappingPipeline::create(mc).value();
  auto merged = map::MergedMap::create(mc.builder.grid).value();
  ExplorationConfig ec;
  ec.planner.seed = seed;
  ec.planner.fan = mc.builder.fan;
  ec.max_submaps = budget;
  auto controller = ExplorationController::create(ec).value();

  Scans scans;
  simulation.start(scans);
  const mission::Box box{scene.bounds_world.min(), scene.bounds_world.max()};
  EXPECT_TRUE(controller.start(scene.T_world_start, box, simulation.stampNs(), true).ok());
  auto estimate = [&] {
    if (pipeline->submaps().empty()) return scans.T_odom_now;
    const slam::SubmapRecord& r = pipeline->submaps().back();
    return Pose3(r.T_world_base * r.T_world_base_odom.inverse() * scans.T_odom_now);
  };
  constexpr std::int64_t kMaxStampNs = 3000'000'000'000;  // at most 3000 s of simulated time
  while (controller.active() && simulation.stampNs() < kMaxStampNs) {
    simulation.step(scans);
    while (!scans.pending.empty()) {
      auto update = pipeline->feed(scans.pending.front());
      scans.pending.pop_front();
      EXPECT_TRUE(update.ok());
      if (update && (update->closed_submap || !update->moved.empty())) {
        EXPECT_TRUE(merged->sync(pipeline->map().entries(), map::MergeConfig{}).ok());
      }
    }
    StepInput in;
    in.stamp_ns = simulation.stampNs();
    in.T_world_vehicle = estimate();
    in.vehicle_idle = simulation.vehicle().waypointsLeft() == 0;
    in.n_submaps = pipeline->submaps().size();
    in.map = [&]() -> Result<std::shared_ptr<const map::MergedMap>> {
      return pipeline->submaps().empty() ? nullptr : merged->snapshot();
    };
    auto out = controller.step(in);
    EXPECT_TRUE(out.ok()) << out.error().message;
    if (!out || !out->waypoints) continue;
    // To the vehicle through the current navigation error, as a controller steering on its estimate.
    const Pose3 T_correction = simulation.vehicle().state().T_world_vehicle() * in.T_world_vehicle.inverse();
    std::vector<sim::Waypoint> wps;
    for (const plan::Waypoint& w : *out->waypoints) {
      m.sent.push_back(w);
      const Pose3 T =
          T_correction * geometry::poseFromXyzRpy(w.p_world.x(), w.p_world.y(), w.p_world.z(), 0, 0, w.yaw_rad);
      wps.push_back({T.translation(), geometry::yawOf(T.linear())});
    }
    EXPECT_TRUE(simulation.vehicle().setWaypoints(std::move(wps)).ok());
  }
  m.ending = controller.ending();
  m.summary = controller.summary();
  m.n_submaps = pipeline->submaps().size();
  m.seconds = 1e-9 * static_cast<double>(simulation.stampNs());
  m.T_true_end = simulation.vehicle().state().T_world_vehicle();
  return m;
}

TEST(ClosedLoop, AShortTankMissionEndsOnItsBudgetAtHomeTheSameWayEveryTime) {
  auto scene = sim::loadScene(test::sourceDir() / "config/scenes/tank.yaml").value();
  const Mission a = runMission(3, 12);
  ASSERT_EQ(a.ending, Ending::kBudget) << a.summary;
  EXPECT_GE(a.n_submaps, 12u);    // the spin alone closes four (a submap closes after 90 deg of heading)
  EXPECT_GT(a.sent.size(), 12u);  // the spin, plans and the way home
  for (const plan::Waypoint& w : a.sent) EXPECT_TRUE(scene.bounds_world.contains(w.p_world)) << w.p_world.transpose();
  // Home in the map frame; the vehicle is within its navigation error of it (thesis Eq. 4.1
  // odometry over about 200 s: well under a metre).
  EXPECT_EQ(a.sent.back().p_world, scene.T_world_start.translation());
  EXPECT_LT((a.T_true_end.translation() - scene.T_world_start.translation()).norm(), 1.0);

  const Mission b = runMission(3, 12);
  EXPECT_EQ(b.summary, a.summary);
  EXPECT_EQ(b.seconds, a.seconds);
  ASSERT_EQ(b.sent.size(), a.sent.size());
  for (std::size_t i = 0; i < a.sent.size(); ++i) {
    EXPECT_EQ(b.sent[i].p_world, a.sent[i].p_world) << i;
    EXPECT_EQ(b.sent[i].yaw_rad, a.sent[i].yaw_rad) << i;
  }
}

// Before the planner checked the turning vehicle as a cylinder, the square around it made the tank's
// start (1.5 m from the wall, toward a diagonal) unsafe once the wall was mapped, and every such
// survey ended "exploration is complete but there is no way home".
TEST(ClosedLoop, AWholeTankSurveyWithLoopClosuresComesHome) {
  auto scene = sim::loadScene(test::sourceDir() / "config/scenes/tank.yaml").value();
  const Mission m = runMission(1, 156, true);
  ASSERT_EQ(m.ending, Ending::kComplete) << m.summary << " after " << m.seconds << " s, " << m.n_submaps << " submaps";
  EXPECT_GT(m.n_submaps, 20u);
  EXPECT_EQ(m.sent.back().p_world, scene.T_world_start.translation());
  EXPECT_LT((m.T_true_end.translation() - scene.T_world_start.translation()).norm(), 1.0);
}

}  // namespace
}  // namespace vog::explore
