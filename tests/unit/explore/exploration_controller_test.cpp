// ExplorationController in simulated time: a vehicle that arrives at its last waypoint a few steps
// after it was sent, on carved maps with exactly known free space (the planner's fixtures).
#include "vog/explore/exploration_controller.hpp"

#include "../plan/plan_fixtures.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace vog::explore {
namespace {

using geometry::Pose3;
constexpr double kPi = std::numbers::pi;
const Eigen::AlignedBox3d kRoom(Eigen::Vector3d(-5.0, -3.0, -3.0), Eigen::Vector3d(5.0, 3.0, -0.5));
const mission::Box kBox{kRoom.min(), kRoom.max()};

ExplorationConfig roomConfig() {
  ExplorationConfig c;
  c.planner.seed = 1;
  c.planner.assume_free_radius_m = 0.0;  // the maps carry all the free space the tests mean
  c.planner.clearance_m = 0.1;
  c.planner.n_tol = 20;  // a fully known room says "nothing left" sooner
  c.planner.max_samples = 200;
  c.planner.global_max_candidates = 20;
  return c;
}

Pose3 poseOf(const Eigen::Vector3d& p, double yaw) { return geometry::poseFromXyzRpy(p.x(), p.y(), p.z(), 0, 0, yaw); }

std::shared_ptr<const map::MergedMap> fullRoom() {
  static const std::shared_ptr<const map::MergedMap> map = [] {
    const map::GridConfig config;
    auto all = [](const map::VoxelKey&) { return true; };
    return plan::test_fixtures::mergedOf(config, {plan::test_fixtures::carvedGrid(config, kRoom, all)})->snapshot();
  }();
  return map;
}

std::shared_ptr<const map::MergedMap> halfRoom() {
  static const std::shared_ptr<const map::MergedMap> map = [] {
    const map::GridConfig config;
    const double res = config.resolution_m;
    const Eigen::AlignedBox3d west(kRoom.min(), Eigen::Vector3d(0.0, kRoom.max().y(), kRoom.max().z()));
    auto west_walls = [&](const map::VoxelKey& k) { return map::keyToCentre(k, res).x() < 0.0; };
    return plan::test_fixtures::mergedOf(config, {plan::test_fixtures::carvedGrid(config, west, west_walls)})
        ->snapshot();
  }();
  return map;
}

// Two known rooms with no way between them.
std::shared_ptr<const map::MergedMap> twoRooms() {
  static const std::shared_ptr<const map::MergedMap> map = [] {
    const map::GridConfig config;
    auto all = [](const map::VoxelKey&) { return true; };
    const Eigen::AlignedBox3d west(kRoom.min(), Eigen::Vector3d(-0.5, kRoom.max().y(), kRoom.max().z()));
    const Eigen::AlignedBox3d east(Eigen::Vector3d(0.5, kRoom.min().y(), kRoom.min().z()), kRoom.max());
    return plan::test_fixtures::mergedOf(config, {plan::test_fixtures::carvedGrid(config, west, all),
                                                  plan::test_fixtures::carvedGrid(config, east, all)})
        ->snapshot();
  }();
  return map;
}

// A simulated vehicle in the map frame: it reaches its last waypoint `travel_steps` steps after
// it was sent; the mission's time advances 100 ms a step.
struct SimVehicle {
  Pose3 T = Pose3::Identity();
  std::vector<plan::Waypoint> waypoints;
  int steps_left = 0;
  int travel_steps = 3;
  std::int64_t stamp_ns = 0;

  void apply(const StepOutput& out) {
    if (!out.waypoints) return;
    waypoints = *out.waypoints;
    steps_left = waypoints.empty() ? 0 : travel_steps;
  }
  void advance() {
    stamp_ns += 100'000'000;
    if (steps_left > 0 && --steps_left == 0) T = poseOf(waypoints.back().p_world, waypoints.back().yaw_rad);
  }
  StepInput input(std::shared_ptr<const map::MergedMap> map, std::size_t n_submaps = 1,
                  int* map_calls = nullptr) const {
    StepInput in;
    in.stamp_ns = stamp_ns;
    in.T_world_vehicle = T;
    in.vehicle_idle = steps_left == 0;
    in.n_submaps = n_submaps;
    in.map = [map, map_calls]() -> Result<std::shared_ptr<const map::MergedMap>> {
      if (map_calls != nullptr) ++*map_calls;
      return map;
    };
    return in;
  }
};

TEST(ExplorationController, ANewMissionTurnsOnTheSpotFirstAndPlansOnlyWhenTheVehicleIsIdle) {
  auto c = ExplorationController::create(roomConfig()).value();
  SimVehicle v;
  v.T = poseOf({-3.0, 0.0, -1.75}, 0.3);
  ASSERT_TRUE(c.start(v.T, kBox, 0, true).ok());
  int map_calls = 0;
  const StepOutput spin = c.step(v.input(nullptr, 0, &map_calls)).value();
  ASSERT_TRUE(spin.waypoints.has_value());
  ASSERT_EQ(spin.waypoints->size(), 4u);
  for (int k = 1; k <= 4; ++k) {
    const plan::Waypoint& w = (*spin.waypoints)[static_cast<std::size_t>(k - 1)];
    EXPECT_EQ(w.p_world, v.T.translation());
    EXPECT_NEAR(geometry::wrapAngle(w.yaw_rad - (0.3 + k * kPi / 2)), 0.0, 1e-12);
  }
  EXPECT_FALSE(spin.plan.has_value());
  EXPECT_FALSE(spin.event.has_value());
  v.apply(spin);
  // While the vehicle turns nothing is planned and the map is not even asked for.
  for (int i = 0; i < 2; ++i) {
    const StepOutput out = c.step(v.input(halfRoom(), 1, &map_calls)).value();
    EXPECT_FALSE(out.waypoints.has_value());
    EXPECT_FALSE(out.plan.has_value());
    v.advance();
  }
  EXPECT_EQ(map_calls, 0);
  // Idle, but nothing merged yet: the step waits.
  v.advance();
  const StepOutput wait = c.step(v.input(nullptr, 0, &map_calls)).value();
  EXPECT_EQ(map_calls, 1);
  EXPECT_FALSE(wait.waypoints.has_value());
  EXPECT_FALSE(wait.plan.has_value());
  // With a map: a plan toward the unknown half.
  const StepOutput plan = c.step(v.input(halfRoom(), 1, &map_calls)).value();
  ASSERT_TRUE(plan.plan.has_value());
  EXPECT_EQ(plan.plan->status, plan::PlanStatus::kExplore);
  ASSERT_TRUE(plan.waypoints.has_value());
  ASSERT_EQ(plan.waypoints->size(), plan.plan->waypoints.size());
  for (std::size_t i = 0; i < plan.waypoints->size(); ++i) {
    EXPECT_EQ((*plan.waypoints)[i].p_world, plan.plan->waypoints[i].p_world);
    EXPECT_EQ((*plan.waypoints)[i].yaw_rad, plan.plan->waypoints[i].yaw_rad);
  }
  EXPECT_TRUE(c.active());
}

TEST(ExplorationController, NothingLeftToExploreGoesHomeAndEndsComplete) {
  auto c = ExplorationController::create(roomConfig()).value();
  SimVehicle v;
  const Pose3 home = poseOf({-3.0, -1.5, -1.75}, 0.0);
  ASSERT_TRUE(c.start(home, kBox, 0, false).ok());
  v.T = poseOf({3.0, 1.5, -1.2}, 2.9);  // somewhere else in the known room
  const StepOutput out = c.step(v.input(fullRoom())).value();
  ASSERT_TRUE(out.plan.has_value());
  EXPECT_EQ(out.plan->status, plan::PlanStatus::kComplete);
  ASSERT_EQ(out.event, mission::MissionEvent::kExplorationDone);
  EXPECT_TRUE(c.returning());
  ASSERT_TRUE(out.waypoints.has_value());
  ASSERT_FALSE(out.waypoints->empty());
  EXPECT_EQ(out.waypoints->back().p_world, home.translation());
  EXPECT_EQ(c.ending(), Ending::kNone);
  v.apply(out);
  StepOutput arrived;
  for (int i = 0; i < 10 && !arrived.event; ++i) {
    v.advance();
    arrived = c.step(v.input(fullRoom())).value();
  }
  EXPECT_EQ(arrived.event, mission::MissionEvent::kArrivedHome);
  EXPECT_FALSE(arrived.plan.has_value());
  EXPECT_EQ(c.ending(), Ending::kComplete);
  EXPECT_FALSE(c.active());
  EXPECT_EQ(c.endingEvent(), mission::MissionEvent::kArrivedHome);
  // Ended: further steps do nothing.
  EXPECT_FALSE(c.step(v.input(fullRoom())).value().waypoints.has_value());
}

// The operator pauses between the step that turns home and the mission hearing of it: the state
// machine ignores the event (it raced with the command). Applying only what the steps said would
// leave the mission exploring for ever, its arrival ignored too; eventsFor() says what is still to be
// heard once the mission moves again, and nothing while it is held or over.
TEST(ExplorationController, EventsThatRacedWithAPauseAreHeardWhenTheMissionMovesAgain) {
  auto c = ExplorationController::create(roomConfig()).value();
  SimVehicle v;
  const Pose3 home = poseOf({-3.0, -1.5, -1.75}, 0.0);
  ASSERT_TRUE(c.start(home, kBox, 0, false).ok());
  v.T = poseOf({3.0, 1.5, -1.2}, 2.9);
  mission::MissionControl m(kBox, mission::MissionState::kExploring);
  EXPECT_TRUE(c.eventsFor(m.state()).empty());
  const StepOutput turn = c.step(v.input(fullRoom())).value();
  ASSERT_EQ(turn.event, mission::MissionEvent::kExplorationDone);
  ASSERT_TRUE(m.command(mission::MissionCommandKind::kPause).ok());
  EXPECT_EQ(m.event(*turn.event), mission::MissionState::kPaused);  // lost in the race
  EXPECT_TRUE(c.eventsFor(m.state()).empty());                      // held: nothing applies
  ASSERT_TRUE(m.command(mission::MissionCommandKind::kResume).ok());
  ASSERT_EQ(m.state(), mission::MissionState::kExploring);
  // The vehicle goes on home and arrives while the mission still says exploring.
  v.apply(turn);
  StepOutput arrived;
  for (int i = 0; i < 10 && !arrived.event; ++i) {
    v.advance();
    arrived = c.step(v.input(fullRoom())).value();
  }
  ASSERT_EQ(arrived.event, mission::MissionEvent::kArrivedHome);
  mission::MissionControl steps_only = m;
  EXPECT_EQ(steps_only.event(*arrived.event), mission::MissionState::kExploring) << "the step's event alone is lost";
  const std::vector<mission::MissionEvent> pending = c.eventsFor(m.state());
  EXPECT_EQ(pending, (std::vector<mission::MissionEvent>{mission::MissionEvent::kExplorationDone,
                                                         mission::MissionEvent::kArrivedHome}));
  for (const mission::MissionEvent e : pending) m.event(e);
  EXPECT_EQ(m.state(), mission::MissionState::kComplete);
  EXPECT_TRUE(c.eventsFor(m.state()).empty());  // over: the ending is not heard again
  // On the way home (the operator's word) only the arrival is to be heard.
  mission::MissionControl returning(kBox, mission::MissionState::kReturning);
  EXPECT_EQ(c.eventsFor(returning.state()), (std::vector<mission::MissionEvent>{mission::MissionEvent::kArrivedHome}));
}

// Nothing left to explore but home is cut off: the vehicle goes to the reachable safe position
// nearest to home and the mission ends near_home, not complete.
TEST(ExplorationController, HomeCutOffEndsAtTheReachablePositionNearestHomeAsNearHome) {
  auto c = ExplorationController::create(roomConfig()).value();
  SimVehicle v;
  const Pose3 home = poseOf({-3.0, 0.0, -1.75}, 0.0);
  ASSERT_TRUE(c.start(home, kBox, 0, false).ok());
  v.T = poseOf({3.0, 0.0, -1.75}, 0.0);
  const StepOutput out = c.step(v.input(twoRooms())).value();
  ASSERT_TRUE(out.plan.has_value());
  EXPECT_EQ(out.plan->status, plan::PlanStatus::kNearHome);
  ASSERT_EQ(out.event, mission::MissionEvent::kExplorationDone);
  ASSERT_TRUE(out.waypoints.has_value());
  ASSERT_FALSE(out.waypoints->empty());
  const Eigen::Vector3d near = out.waypoints->back().p_world;
  EXPECT_GT(near.x(), 0.0);  // in the vehicle's room, on the side toward home
  EXPECT_LT(near.x(), 2.0);
  v.apply(out);
  StepOutput arrived;
  for (int i = 0; i < 10 && !arrived.event; ++i) {
    v.advance();
    arrived = c.step(v.input(twoRooms())).value();
  }
  EXPECT_EQ(arrived.event, mission::MissionEvent::kArrivedNearHome);
  EXPECT_EQ(c.ending(), Ending::kNearHome);
  EXPECT_EQ(c.summary().rfind("near_home: ", 0), 0u) << c.summary();
  EXPECT_NE(c.summary().find("not reachable through known free space"), std::string::npos) << c.summary();
  // The mission hears both, and ends in its own word.
  mission::MissionControl m(kBox, mission::MissionState::kExploring);
  for (const mission::MissionEvent e : c.eventsFor(m.state())) m.event(e);
  EXPECT_EQ(m.state(), mission::MissionState::kNearHome);
  EXPECT_TRUE(m.ended());
}

TEST(ExplorationController, TheSubmapBudgetEndsTheExplorationOnTheWayHome) {
  ExplorationConfig config = roomConfig();
  config.max_submaps = 5;
  auto c = ExplorationController::create(config).value();
  SimVehicle v;
  const Pose3 home = poseOf({-3.0, 0.0, -1.75}, kPi);
  v.T = poseOf({-1.5, 1.0, -1.75}, 0.0);
  ASSERT_TRUE(c.start(home, kBox, 0, false).ok());
  // Below the budget it explores the half-known room.
  StepOutput out = c.step(v.input(halfRoom(), 4)).value();
  ASSERT_TRUE(out.plan.has_value());
  EXPECT_EQ(out.plan->status, plan::PlanStatus::kExplore);
  EXPECT_FALSE(out.event.has_value());
  v.apply(out);
  for (int i = 0; i < 3; ++i) v.advance();
  // At the budget: home, although unknown space is left.
  out = c.step(v.input(halfRoom(), 5)).value();
  ASSERT_EQ(out.event, mission::MissionEvent::kExplorationDone);
  EXPECT_NE(out.reason.find("submap budget of 5"), std::string::npos) << out.reason;
  ASSERT_TRUE(out.waypoints.has_value());
  EXPECT_EQ(out.waypoints->back().p_world, home.translation());
  EXPECT_NEAR(geometry::wrapAngle(out.waypoints->back().yaw_rad - kPi), 0.0, 1e-12);
  v.apply(out);
  for (int i = 0; i < 3; ++i) v.advance();
  out = c.step(v.input(halfRoom(), 6)).value();
  EXPECT_EQ(out.event, mission::MissionEvent::kArrivedHome);
  EXPECT_EQ(c.ending(), Ending::kBudget);
  EXPECT_EQ(c.summary().rfind("budget", 0), 0u) << c.summary();
}

TEST(ExplorationController, AnObstructionBacksTheVehicleOffAndOnTheWayHomeIsNotAnArrival) {
  auto c = ExplorationController::create(roomConfig()).value();
  SimVehicle v;
  const Pose3 home = poseOf({-3.0, -1.5, -1.75}, 0.0);
  ASSERT_TRUE(c.start(home, kBox, 0, false).ok());
  v.T = poseOf({2.0, 0.0, -1.75}, 0.0);
  StepOutput out = c.step(v.input(fullRoom())).value();
  ASSERT_EQ(out.event, mission::MissionEvent::kExplorationDone);
  v.apply(out);
  v.advance();
  // Stopped short on the way home: it holds, backs off the way it came, and the way home is
  // planned again from there; the stop is not taken for the arrival.
  const Eigen::Vector3d stopped(1.0, 0.0, -1.75);
  v.T = poseOf(stopped, kPi);
  StepInput in = v.input(fullRoom());
  in.vehicle_idle = false;  // its waypoints are still there: the obstruction stopped it
  in.obstruction = Obstruction{stopped, Eigen::Vector3d(-1.0, 0.0, -1.75)};
  out = c.step(in).value();
  EXPECT_FALSE(out.event.has_value());
  EXPECT_EQ(c.ending(), Ending::kNone);
  ASSERT_TRUE(out.plan.has_value());
  ASSERT_TRUE(out.waypoints.has_value());
  ASSERT_FALSE(out.waypoints->empty());
  EXPECT_EQ(out.waypoints->back().p_world, home.translation());  // the way home again
  EXPECT_TRUE(c.returning());
  v.apply(out);
  for (int i = 0; i < 3; ++i) v.advance();
  out = c.step(v.input(fullRoom())).value();
  EXPECT_EQ(out.event, mission::MissionEvent::kArrivedHome);

  // While exploring: the obstruction turns into the planner's back-off move at once.
  auto e = ExplorationController::create(roomConfig()).value();
  ASSERT_TRUE(e.start(home, kBox, 0, false).ok());
  SimVehicle w;
  w.T = poseOf({-2.0, 0.0, -1.75}, 0.0);
  StepInput moving = w.input(halfRoom());
  moving.vehicle_idle = false;
  moving.obstruction = Obstruction{Eigen::Vector3d(-2.0, 0.0, -1.75), Eigen::Vector3d(0.0, 0.0, -1.75)};
  out = e.step(moving).value();
  ASSERT_TRUE(out.plan.has_value());
  EXPECT_NE(out.plan->reason.find("backing off"), std::string::npos) << out.plan->reason;
  ASSERT_TRUE(out.waypoints.has_value());
  ASSERT_EQ(out.waypoints->size(), 1u);
  EXPECT_LT(((*out.waypoints)[0].p_world - Eigen::Vector3d(-2.3, 0.0, -1.75)).norm(), 1e-9);
}

TEST(ExplorationController, TheOperatorsReturnHomeAndAHoldPlanTheWayHomeAgain) {
  auto c = ExplorationController::create(roomConfig()).value();
  SimVehicle v;
  const Pose3 home = poseOf({-3.0, 0.0, -1.75}, kPi);
  v.T = home;
  ASSERT_TRUE(c.start(home, kBox, 0, false).ok());
  StepOutput out = c.step(v.input(halfRoom())).value();
  ASSERT_EQ(out.plan->status, plan::PlanStatus::kExplore);
  v.apply(out);
  for (int i = 0; i < 3; ++i) v.advance();
  c.returnHome();
  EXPECT_TRUE(c.returning());
  out = c.step(v.input(halfRoom())).value();
  EXPECT_FALSE(out.event.has_value());  // the mission is returning on the operator's word already
  ASSERT_TRUE(out.waypoints.has_value());
  EXPECT_EQ(out.waypoints->back().p_world, home.translation());
  v.apply(out);
  v.advance();
  // Paused on the way: the vehicle was stopped, so the way home is planned again, not arrived at.
  c.hold();
  v.steps_left = 0;
  out = c.step(v.input(halfRoom())).value();
  EXPECT_FALSE(out.event.has_value());
  ASSERT_TRUE(out.waypoints.has_value());
  EXPECT_EQ(out.waypoints->back().p_world, home.translation());
  EXPECT_EQ(c.ending(), Ending::kNone);
}

// Sent home from where no safe position is within reach (deep in unknown space): no way at all, the
// mission ends no_path with the reason and the vehicle holds.
TEST(ExplorationController, NoWayAtAllEndsTheMissionWithTheReason) {
  auto c = ExplorationController::create(roomConfig()).value();
  SimVehicle v;
  ASSERT_TRUE(c.start(poseOf({-3.0, 0.0, -1.75}, 0.0), kBox, 0, false).ok());
  v.T = poseOf({3.0, 0.0, -1.75}, 0.0);  // the unknown half of the room
  c.returnHome();
  const StepOutput out = c.step(v.input(halfRoom())).value();
  EXPECT_EQ(out.event, mission::MissionEvent::kNoPath);
  EXPECT_EQ(c.ending(), Ending::kNoPath);
  EXPECT_NE(out.reason.find("no way home"), std::string::npos) << out.reason;
  EXPECT_NE(out.reason.find("root_tolerance_m"), std::string::npos) << out.reason;
  EXPECT_EQ(out.reason.rfind("no_path: ", 0), 0u) << out.reason;
  ASSERT_TRUE(out.waypoints.has_value());
  EXPECT_TRUE(out.waypoints->empty());  // hold
  EXPECT_FALSE(c.active());
  EXPECT_EQ(c.endingEvent(), mission::MissionEvent::kNoPath);
}

TEST(ExplorationController, PlansThatNeverMoveTheVehicleEndAsStalled) {
  ExplorationConfig config = roomConfig();
  config.max_idle_plans = 3;
  auto c = ExplorationController::create(config).value();
  SimVehicle v;
  v.T = poseOf({-3.0, 0.0, -1.75}, kPi);
  ASSERT_TRUE(c.start(v.T, kBox, 0, false).ok());
  // The vehicle never moves (it stays idle where it is): the fourth plan in a row ends the mission.
  int plans = 0;
  StepOutput out;
  while (!out.event && plans < 10) {
    out = c.step(v.input(halfRoom())).value();
    ASSERT_TRUE(out.plan.has_value());
    ++plans;
  }
  EXPECT_EQ(plans, 4);
  EXPECT_EQ(out.event, mission::MissionEvent::kNoPath);
  EXPECT_EQ(c.ending(), Ending::kStalled);
  // Any step with the vehicle moving resets the count.
  auto d = ExplorationController::create(config).value();
  ASSERT_TRUE(d.start(v.T, kBox, 0, false).ok());
  for (int i = 0; i < 8; ++i) {
    StepInput in = v.input(halfRoom());
    in.vehicle_idle = i % 2 == 1;
    EXPECT_FALSE(d.step(in).value().event.has_value()) << "step " << i;
  }
}

// vogd polls its vehicle: one that reaches each plan's waypoints between two polls is idle at every
// step, yet it moves, and a mission of many plans does not end as stalled.
TEST(ExplorationController, AVehicleThatReachesEveryPlanBetweenStepsIsNotStalled) {
  ExplorationConfig config = roomConfig();
  config.max_idle_plans = 3;
  auto c = ExplorationController::create(config).value();
  SimVehicle v;
  v.T = poseOf({-3.0, 0.0, -1.75}, kPi);
  ASSERT_TRUE(c.start(v.T, kBox, 0, false).ok());
  int plans = 0;
  for (int i = 0; i < 12; ++i) {
    const StepOutput out = c.step(v.input(halfRoom())).value();
    if (out.event) break;
    ASSERT_TRUE(out.waypoints.has_value() && !out.waypoints->empty());
    ++plans;
    v.T = poseOf(out.waypoints->back().p_world, out.waypoints->back().yaw_rad);  // reached before the next step
  }
  EXPECT_GT(plans, config.max_idle_plans);
  EXPECT_NE(c.ending(), Ending::kStalled) << c.summary();
}

TEST(ExplorationController, RevisitsGoBackToAnOldViewWhenNoClosureAnchoredTheMapForTooLong) {
  ExplorationConfig config = roomConfig();
  config.revisits = true;
  config.revisit.after_s = 10.0;
  config.revisit.anchor_span_s = 5.0;
  auto c = ExplorationController::create(config).value();
  SimVehicle v;
  v.T = poseOf({-3.5, 0.0, -1.75}, kPi);
  ASSERT_TRUE(c.start(v.T, kBox, 0, false).ok());
  std::vector<slam::SubmapRecord> submaps(2);
  submaps[0].index = 0;
  submaps[0].T_world_base = poseOf({-1.0, 1.5, -1.75}, -2.0);  // an old view in the known half
  submaps[0].first_stamp_ns = 0;
  submaps[1].index = 1;
  submaps[1].T_world_base = v.T;
  submaps[1].first_stamp_ns = 11'000'000'000;
  const std::vector<slam::ClosurePair> closures;
  StepInput in = v.input(halfRoom(), 2);
  in.submaps = &submaps;
  in.closures = &closures;
  in.stamp_ns = 5'000'000'000;  // not due yet
  StepOutput out = c.step(in).value();
  EXPECT_EQ(out.plan->reason.rfind("revisit", 0), std::string::npos) << out.plan->reason;
  EXPECT_EQ(c.revisits(), 0);
  in.stamp_ns = 12'000'000'000;  // 12 s without an anchoring closure
  out = c.step(in).value();
  EXPECT_EQ(out.plan->reason.rfind("revisit", 0), 0u) << out.plan->reason;
  EXPECT_EQ(c.revisits(), 1);
  ASSERT_TRUE(out.waypoints.has_value());
  EXPECT_LE((out.waypoints->back().p_world - submaps[0].T_world_base.translation()).norm(),
            config.planner.root_tolerance_m);
}

TEST(ExplorationController, SameInputsSameMissionBitForBit) {
  auto run = [] {
    auto c = ExplorationController::create(roomConfig()).value();
    SimVehicle v;
    v.T = poseOf({-3.5, 0.0, -1.75}, kPi);
    EXPECT_TRUE(c.start(v.T, kBox, 0, true).ok());
    std::vector<plan::Waypoint> sent;
    for (int i = 0; i < 40; ++i) {
      const StepOutput out = c.step(v.input(halfRoom())).value();
      if (out.waypoints) sent.insert(sent.end(), out.waypoints->begin(), out.waypoints->end());
      v.apply(out);
      v.advance();
    }
    return sent;
  };
  const std::vector<plan::Waypoint> a = run(), b = run();
  ASSERT_GT(a.size(), 4u);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].p_world, b[i].p_world) << i;
    EXPECT_EQ(a[i].yaw_rad, b[i].yaw_rad) << i;
  }
}

TEST(ExplorationController, BadInputIsAnErrorThatNamesIt) {
  ExplorationConfig config = roomConfig();
  config.max_submaps = 0;
  EXPECT_NE(ExplorationController::create(config).error().message.find("max_submaps"), std::string::npos);
  config = roomConfig();
  config.revisits = true;
  config.revisit.after_s = -1.0;
  EXPECT_FALSE(ExplorationController::create(config).ok());
  auto c = ExplorationController::create(roomConfig()).value();
  const Status outside = c.start(poseOf({9.0, 0.0, -1.75}, 0.0), kBox, 0, true);
  ASSERT_FALSE(outside.ok());
  EXPECT_FALSE(c.active());
  ASSERT_TRUE(c.start(poseOf({-3.0, 0.0, -1.75}, 0.0), kBox, 0, false).ok());
  SimVehicle v;
  v.T = poseOf({-3.0, 0.0, NAN}, 0.0);
  const auto r = c.step(v.input(halfRoom()));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("not finite"), std::string::npos) << r.error().message;
  EXPECT_TRUE(c.active());  // the caller's input was wrong; the mission is unchanged
  // The caller's own error from the map is passed on.
  v.T = poseOf({-3.0, 0.0, -1.75}, 0.0);
  StepInput in = v.input(halfRoom());
  in.map = []() -> Result<std::shared_ptr<const map::MergedMap>> { return Error{"merge failed"}; };
  EXPECT_EQ(c.step(in).error().message, "merge failed");
}

}  // namespace
}  // namespace vog::explore
