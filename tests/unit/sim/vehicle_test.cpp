#include "vog/sim/vehicle.hpp"

#include "world_from_text.hpp"

#include <gtest/gtest.h>

namespace vog::sim {
namespace {

constexpr std::int64_t kDtNs = 10'000'000;  // 100 Hz

TEST(Vehicle, ReachesWaypointsWithinTheSpeedAndYawRateLimits) {
  const auto w = worldFrom("  []\n");
  VehicleConfig cfg;
  auto v = VehicleModel::create(*w, cfg, Eigen::Vector3d(0, 0, -2), 0.0, 0);
  ASSERT_TRUE(v.ok()) << v.error().message;
  ASSERT_TRUE(v->setWaypoints({{Eigen::Vector3d(3, 4, -3), 1.0}, {Eigen::Vector3d(3, 4, -3), -2.0}}).ok());
  int reached = 0;
  double t_first = 0;
  for (int i = 0; i < 100000 && v->waypointsLeft() > 0; ++i) {
    const Eigen::Vector3d p0 = v->state().xyz_world;
    const double y0 = v->state().yaw_rad;
    const StepResult r = v->step(kDtNs);
    const double dt = 1e-2;
    EXPECT_LE((v->state().xyz_world - p0).norm(), cfg.max_speed_mps * dt + 1e-12);
    EXPECT_LE(std::abs(geometry::wrapAngle(v->state().yaw_rad - y0)), cfg.max_yaw_rate_radps * dt + 1e-12);
    if (r.waypoints_reached > 0 && reached == 0) t_first = static_cast<double>(v->state().stamp_ns) * 1e-9;
    reached += r.waypoints_reached;
  }
  EXPECT_EQ(reached, 2);
  EXPECT_EQ(v->state().xyz_world, Eigen::Vector3d(3, 4, -3));
  EXPECT_NEAR(v->state().yaw_rad, -2.0, 1e-12);
  // Leg 1 is limited by distance: sqrt(9 + 16 + 1) / 0.25 s (the turn of 1 rad takes 6.7 s).
  EXPECT_NEAR(t_first, std::sqrt(26.0) / 0.25, 0.02);
  EXPECT_EQ(v->collisionCount(), 0u);
}

TEST(Vehicle, IsBlockedByAWallAndNeverPassesThrough) {
  const auto w = worldFrom("  - {type: plane, pose: {xyz: [3, 0, 0], rpy_deg: [0, 90, 0]}, size: [10, 10]}\n");
  VehicleConfig cfg;
  auto v = VehicleModel::create(*w, cfg, Eigen::Vector3d(0, 0, 0), 0.0, 0);
  ASSERT_TRUE(v.ok());
  ASSERT_TRUE(v->setWaypoints({{Eigen::Vector3d(6, 0, 0), 0.0}}).ok());
  MotionStatus last = MotionStatus::kMoving;
  for (int i = 0; i < 5000 && last != MotionStatus::kBlocked; ++i) {
    last = v->step(kDtNs).status;
    EXPECT_FALSE(v->collidesAt(v->state().xyz_world, v->state().yaw_rad));
    EXPECT_LT(v->state().xyz_world.x(), 2.5);
  }
  EXPECT_EQ(last, MotionStatus::kBlocked);
  EXPECT_TRUE(v->blocked());
  EXPECT_EQ(v->collisionCount(), 1u);
  // Stopped within one collision-check step of the wall (front face at x + 0.5 = 3).
  EXPECT_NEAR(v->state().xyz_world.x(), 2.5, cfg.max_check_step_m + 1e-9);
  // A blocked vehicle stays put until told otherwise.
  const Eigen::Vector3d stopped = v->state().xyz_world;
  EXPECT_EQ(v->step(kDtNs).status, MotionStatus::kBlocked);
  EXPECT_EQ(v->state().xyz_world, stopped);
  // One big step (10 s) must not jump through either.
  ASSERT_TRUE(v->setWaypoints({{Eigen::Vector3d(6, 0, 0), 0.0}}).ok());
  v->step(10'000'000'000);
  EXPECT_LT(v->state().xyz_world.x(), 2.5 + 1e-9);
  v->skipWaypoint();
  EXPECT_FALSE(v->blocked());
  EXPECT_EQ(v->step(kDtNs).status, MotionStatus::kIdle);
}

TEST(Vehicle, TurningInPlaceNextToAPilingIsChecked) {
  // A piling just clear of the box's face but inside the circle swept by its corners.
  const auto w = worldFrom("  - {type: cylinder, pose: {xyz: [0.75, 0, 0]}, radius: 0.2, length: 4}\n");
  auto v = VehicleModel::create(*w, VehicleConfig{}, Eigen::Vector3d(0, 0, 0), 0.0, 0);
  ASSERT_TRUE(v.ok()) << v.error().message;
  ASSERT_TRUE(v->setWaypoints({{Eigen::Vector3d(0, 0, 0), 0.7}}).ok());
  MotionStatus last = MotionStatus::kMoving;
  for (int i = 0; i < 1000 && last == MotionStatus::kMoving; ++i) last = v->step(kDtNs).status;
  EXPECT_EQ(last, MotionStatus::kBlocked);
  EXPECT_FALSE(v->collidesAt(v->state().xyz_world, v->state().yaw_rad));
  EXPECT_GT(v->state().yaw_rad, 0.0);
}

TEST(Vehicle, BadInputIsAnError) {
  const auto w = worldFrom("  - {type: box, pose: {xyz: [0, 0, 0]}, size: [2, 2, 2]}\n");
  EXPECT_FALSE(VehicleModel::create(*w, VehicleConfig{}, Eigen::Vector3d(0, 0, 0), 0.0, 0).ok());  // inside the box
  VehicleConfig bad;
  bad.max_speed_mps = -1;
  auto r = VehicleModel::create(*w, bad, Eigen::Vector3d(5, 0, 0), 0.0, 0);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("vehicle.max_speed_mps"), std::string::npos);
  bad = VehicleConfig{};
  bad.max_check_step_m = 0.6;
  EXPECT_FALSE(bad.validate().ok());
  auto v = VehicleModel::create(*w, VehicleConfig{}, Eigen::Vector3d(5, 0, 0), 0.0, 0);
  ASSERT_TRUE(v.ok());
  EXPECT_FALSE(v->setWaypoints({{Eigen::Vector3d(NAN, 0, 0), 0.0}}).ok());
}

}  // namespace
}  // namespace vog::sim
