// The backseat waypoint exchange as the vehicle sees it: every sentence the follower writes is
// decoded with the backseat codec, acknowledged or not, and the vehicle's navigation is played back.
#include "vog/app/waypoint_follower.hpp"

#include "vog/backseat/backseat.hpp"

#include <gtest/gtest.h>

#include <numbers>

namespace vog::app {
namespace {

constexpr std::int64_t kS = 1'000'000'000;

struct Vehicle {
  backseat::LocalTangentPlane ltp = backseat::LocalTangentPlane::create({42.0, -71.0}).value();
  WaypointFollower follower{WaypointFollowerConfig{}, ltp};
  std::vector<backseat::WaypointCommand> commands;
  int heartbeats = 0;
  std::int64_t now = 0;

  // Polls at `now` and decodes what was written.
  void poll() {
    for (const std::string& s : follower.poll(now, {100.0}, 1, "mapping")) {
      auto r = backseat::BackseatCodec{}.decode(
          std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()));
      ASSERT_TRUE(r.isFrame()) << s;
      if (const auto* c = std::get_if<backseat::WaypointCommand>(&r.frame())) commands.push_back(*c);
      if (std::holds_alternative<backseat::Heartbeat>(r.frame())) ++heartbeats;
    }
  }
  void ack(std::uint32_t id, bool accepted, const std::string& reason = "") {
    follower.onAck(
        {now, {}, "BPGHP", {}, id, accepted ? backseat::AckStatus::kAccepted : backseat::AckStatus::kFailed, reason});
  }
  // The vehicle's navigation at (x, y, z, yaw) with a speed; odometry = navigation + odom_shift.
  void at(const Eigen::Vector3d& p, double yaw, double speed,
          const Eigen::Vector3d& odom_shift = Eigen::Vector3d::Zero()) {
    VehicleNavigation n;
    n.stamp_ns = now;
    n.T_world_vehicle = geometry::poseFromXyzRpy(p.x(), p.y(), p.z(), 0, 0, yaw);
    n.velocity_world_mps = Eigen::Vector3d(speed, 0, 0);
    geometry::Pose3 T_odom = n.T_world_vehicle;
    T_odom.translation() += odom_shift;
    follower.onNavigation(n, T_odom);
  }
  Eigen::Vector3d targetOf(const backseat::WaypointCommand& c) const {
    const Eigen::Vector2d xy = ltp.toLocal({c.latitude_deg, c.longitude_deg});
    return {xy.x(), xy.y(), -c.depth_m};
  }
};

TEST(WaypointFollower, WaypointsGoOneAtATimeAndAdvanceOnArrival) {
  Vehicle v;
  v.at({0, 0, -2}, 0.0, 0.0);
  v.follower.setWaypoints({{Eigen::Vector3d(2, 0, -2), 0.0}, {Eigen::Vector3d(2, 1, -2), std::numbers::pi / 2}});
  EXPECT_FALSE(v.follower.idle());
  v.poll();
  ASSERT_EQ(v.commands.size(), 1u);
  EXPECT_EQ(v.heartbeats, 1);
  EXPECT_LT((v.targetOf(v.commands[0]) - Eigen::Vector3d(2, 0, -2)).norm(), 0.005);
  ASSERT_TRUE(v.commands[0].heading_deg.has_value());
  EXPECT_NEAR(*v.commands[0].heading_deg, 90.0, 0.01);  // world yaw 0 = east
  EXPECT_DOUBLE_EQ(v.commands[0].speed_mps, 0.25);
  v.ack(v.commands[0].id, true);
  // On the way: nothing new.
  v.now += kS / 2;
  v.at({1, 0, -2}, 0.0, 0.25);
  v.poll();
  EXPECT_EQ(v.commands.size(), 1u);
  // There, but still moving: not yet.
  v.at({2, 0, -2}, 0.0, 0.1);
  v.poll();
  EXPECT_EQ(v.commands.size(), 1u);
  v.at({2.05, 0, -2}, 0.01, 0.0);  // within 0.15 m and 3 deg, stopped
  v.poll();
  ASSERT_EQ(v.commands.size(), 2u);
  EXPECT_NEAR(*v.commands[1].heading_deg, 0.0, 0.01);  // north
  v.ack(v.commands[1].id, true);
  v.at({2, 1, -2}, std::numbers::pi / 2, 0.0);
  v.poll();
  EXPECT_TRUE(v.follower.idle());
  EXPECT_EQ(v.follower.stats().arrived, 2u);
  EXPECT_EQ(v.follower.stats().accepted, 2u);
}

TEST(WaypointFollower, WaypointsAreSentInTheVehiclesNavigationFrame) {
  Vehicle v;
  // The daemon's odometry is 0.4 m north of the vehicle's navigation.
  v.at({0, 0, -2}, 0.0, 0.0, Eigen::Vector3d(0, 0.4, 0));
  v.follower.setWaypoints({{Eigen::Vector3d(3, 0.4, -2), 0.0}});
  v.poll();
  ASSERT_EQ(v.commands.size(), 1u);
  EXPECT_LT((v.targetOf(v.commands[0]) - Eigen::Vector3d(3, 0, -2)).norm(), 0.005);
}

TEST(WaypointFollower, RefusedOrUnacknowledgedCommandsDropTheListAndSayWhy) {
  Vehicle v;
  v.at({0, 0, -2}, 0.0, 0.0);
  v.follower.setWaypoints({{Eigen::Vector3d(2, 0, -2), 0.0}, {Eigen::Vector3d(4, 0, -2), 0.0}});
  v.poll();
  v.ack(v.commands[0].id, false, "outside the operating area");
  v.poll();
  EXPECT_TRUE(v.follower.idle());
  EXPECT_EQ(v.follower.stats().refused, 1u);
  EXPECT_NE(v.follower.lastError().find("outside the operating area"), std::string::npos) << v.follower.lastError();

  // No acknowledgement at all: resent after 5 s, twice, then given up.
  v.follower.setWaypoints({{Eigen::Vector3d(1, 0, -2), 0.0}});
  v.poll();
  ASSERT_EQ(v.commands.size(), 2u);
  for (int k = 0; k < 3; ++k) {
    v.now += 5 * kS;
    v.poll();
  }
  EXPECT_EQ(v.commands.size(), 4u);  // the first send and two resends, same id
  EXPECT_EQ(v.commands[3].id, v.commands[1].id);
  EXPECT_TRUE(v.follower.idle());
  EXPECT_NE(v.follower.lastError().find("no acknowledgement after 3 attempts"), std::string::npos)
      << v.follower.lastError();
}

TEST(WaypointFollower, AVehicleThatStopsShortIsReportedAsObstructed) {
  Vehicle v;
  v.at({0, 0, -2}, 0.0, 0.0);
  // 2 m at 0.25 m/s: 8 s; twice that plus the 10 s margin is the deadline.
  v.follower.setWaypoints({{Eigen::Vector3d(2, 0, -2), 0.0}, {Eigen::Vector3d(4, 0, -2), 0.0}});
  v.poll();
  v.ack(v.commands[0].id, true);
  v.now += 20 * kS;
  v.at({1.2, 0, -2}, 0.0, 0.0);  // stopped 0.8 m short
  v.poll();
  EXPECT_FALSE(v.follower.idle());
  EXPECT_FALSE(v.follower.takeObstruction().has_value());
  v.now += 7 * kS;  // 27 s > 26 s
  v.poll();
  EXPECT_TRUE(v.follower.idle());
  EXPECT_EQ(v.follower.stats().timeouts, 1u);
  EXPECT_EQ(v.commands.size(), 1u);  // the second waypoint was never sent
  EXPECT_NE(v.follower.lastError().find("0.80 m short"), std::string::npos) << v.follower.lastError();
  const auto stopped = v.follower.takeObstruction();
  ASSERT_TRUE(stopped.has_value());
  EXPECT_LT((stopped->p_odom_m - Eigen::Vector3d(1.2, 0, -2)).norm(), 1e-9);
  EXPECT_LT((stopped->target_odom_m - Eigen::Vector3d(2, 0, -2)).norm(), 0.005);
  EXPECT_FALSE(v.follower.takeObstruction().has_value());  // once
}

TEST(WaypointFollower, AnEmptyListHoldsTheVehicleWhereItIs) {
  Vehicle v;
  v.follower.setWaypoints({});
  v.poll();
  EXPECT_TRUE(v.commands.empty());  // no navigation yet: nothing to hold at
  EXPECT_FALSE(v.follower.idle());
  v.at({1.5, -2, -3}, 1.0, 0.2);
  v.poll();
  ASSERT_EQ(v.commands.size(), 1u);
  EXPECT_LT((v.targetOf(v.commands[0]) - Eigen::Vector3d(1.5, -2, -3)).norm(), 0.005);
  EXPECT_NEAR(*v.commands[0].heading_deg, 90.0 - 1.0 * 180.0 / std::numbers::pi, 0.01);
  EXPECT_TRUE(v.follower.idle());
}

TEST(WaypointFollower, WithoutABackseatArrivalIsJudgedOnTheOdometryGiven) {
  backseat::LocalTangentPlane ltp = backseat::LocalTangentPlane::create({42.0, -71.0}).value();
  WaypointFollowerConfig c;
  c.expect_acks = false;
  WaypointFollower f(c, ltp);
  f.setWaypoints({{Eigen::Vector3d(1, 0, -2), 0.0}});
  VehicleNavigation n;
  n.T_world_vehicle = geometry::poseFromXyzRpy(0, 0, -2, 0, 0, 0);
  f.onNavigation(n, n.T_world_vehicle);
  EXPECT_EQ(f.poll(0, {0.0}, 1, "").size(), 2u);  // the command (nobody acknowledges it) and the heartbeat
  EXPECT_FALSE(f.idle());
  n.T_world_vehicle = geometry::poseFromXyzRpy(1, 0, -2, 0, 0, 0);
  f.onNavigation(n, n.T_world_vehicle);
  (void)f.poll(100'000'000, {0.1}, 1, "");
  EXPECT_TRUE(f.idle());
  EXPECT_EQ(f.stats().refused, 0u);
}

TEST(WaypointFollower, ConfigurationIsChecked) {
  WaypointFollowerConfig c;
  EXPECT_TRUE(c.validate().ok());
  c.arrival_tolerance_m = 0.0;
  EXPECT_NE(c.validate().error().message.find("arrival_tolerance_m"), std::string::npos);
  c = WaypointFollowerConfig{};
  c.ack.max_attempts = 0;
  EXPECT_FALSE(c.validate().ok());
}

}  // namespace
}  // namespace vog::app
