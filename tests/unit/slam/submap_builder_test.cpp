// SubmapBuilder (thesis 3.2, 4.5.3): each closing rule triggers at the right scan, grids are in the
// base frame, the odometry between base poses is planarOdometry with covariance dt * Sigma, and bad
// input is rejected without changing state.
#include "pipeline_fixture.hpp"
#include "synthetic_scene.hpp"
#include "vog/slam/submap_builder.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace vog::slam {
namespace {

using geometry::deg2rad;

// A scan of the pier from a pose, stamped t_s seconds.
ScanInput scanAt(const geometry::Pose3& T_world_vehicle, double t_s) {
  static const test::SyntheticScene scene = test::SyntheticScene::pier();
  std::mt19937_64 rng(7);
  ScanInput in;
  in.T_world_vehicle_odom = T_world_vehicle;
  in.z_roll_pitch = Eigen::Vector3d(T_world_vehicle.translation().z(), 0.0, 0.0);
  in.scan = scene.scan(T_world_vehicle, geometry::SonarFan{}, 0.0, rng);
  in.scan.stamp_ns = static_cast<std::int64_t>(std::llround(t_s * 1e9));
  return in;
}

// Limits that never trigger unless a test lowers one.
SubmapBuilderConfig looseConfig() {
  SubmapBuilderConfig c;
  c.max_scans = 1000;
  c.max_position_stddev_m = 100.0;
  c.max_yaw_stddev_rad = 100.0;
  c.max_heading_change_rad = std::numbers::pi;
  c.grid.resolution_m = 0.2;
  c.grid.cloud_voxel_m = 0.4;
  return c;
}

geometry::Pose3 poseAt(double x, double yaw_deg) {
  return geometry::poseFromXyzRpy(x, -5.0, -2.0, 0, 0, deg2rad(yaw_deg));
}

TEST(SubmapBuilder, ClosesOnScanCountWhenTheNextScanArrives) {
  SubmapBuilderConfig c = looseConfig();
  c.max_scans = 10;
  auto b = SubmapBuilder::create(c);
  ASSERT_TRUE(b.ok()) << b.error().message;
  for (int k = 0; k < 25; ++k) {
    auto r = b->addScan(scanAt(poseAt(0.05 * k, 90.0), 0.2 * (k + 1)));
    ASSERT_TRUE(r.ok()) << r.error().message;
    const bool expect_close = k == 10 || k == 20;
    ASSERT_EQ(r->has_value(), expect_close) << "scan " << k;
    if (expect_close) {
      EXPECT_EQ((*r)->n_scans, 10U);
      EXPECT_EQ((*r)->reason, CloseReason::kScanCount);
      EXPECT_EQ((*r)->index, k / 10 - 1);
      EXPECT_EQ((*r)->first_stamp_ns, std::llround(0.2 * (k - 9) * 1e9));
      EXPECT_EQ((*r)->last_stamp_ns, std::llround(0.2 * k * 1e9));
      EXPECT_TRUE((*r)->grid->finalized());
      EXPECT_EQ((*r)->grid->scanCount(), 10U);
    }
  }
  EXPECT_EQ(b->activeScanCount(), 5U);
  auto f = b->flush();
  ASSERT_TRUE(f.ok());
  ASSERT_TRUE(f->has_value());
  EXPECT_EQ((*f)->n_scans, 5U);
  EXPECT_EQ((*f)->reason, CloseReason::kFlush);
  auto again = b->flush();
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(again->has_value());
}

TEST(SubmapBuilder, ClosesWhenAccumulatedPositionUncertaintyExceedsTheBound) {
  SubmapBuilderConfig c = looseConfig();
  c.odometry_cov_x_m2_per_s = 0.005;
  c.odometry_cov_y_m2_per_s = 0.005;  // Sigma_i = dt * 0.01 m^2 (thesis 3.2)
  c.max_position_stddev_m = 0.21;     // variance 0.0441: dt = 4 s is inside, 5 s outside
  auto b = SubmapBuilder::create(c);
  ASSERT_TRUE(b.ok());
  for (int k = 0; k < 6; ++k) {
    auto r = b->addScan(scanAt(poseAt(0.25 * k, 90.0), 1.0 * k + 1.0));  // one scan per second
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->has_value(), k == 5) << "scan " << k;
    if (k == 5) {
      EXPECT_EQ((*r)->reason, CloseReason::kUncertainty);
      EXPECT_EQ((*r)->n_scans, 5U);
    }
  }
}

TEST(SubmapBuilder, ClosesWhenAccumulatedYawUncertaintyExceedsTheBound) {
  SubmapBuilderConfig c = looseConfig();
  c.odometry_cov_yaw_rad2_per_s = 1e-4;
  c.max_yaw_stddev_rad = 0.0305;  // variance 9.3e-4: dt = 9 s is inside, 10 s outside
  auto b = SubmapBuilder::create(c);
  ASSERT_TRUE(b.ok());
  for (int k = 0; k < 11; ++k) {
    auto r = b->addScan(scanAt(poseAt(0.25 * k, 90.0), 1.0 * k + 1.0));
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->has_value(), k == 10) << "scan " << k;
    if (k == 10) {
      EXPECT_EQ((*r)->reason, CloseReason::kUncertainty);
    }
  }
}

TEST(SubmapBuilder, ClosesOnHeadingChangeFromTheBasePose) {
  SubmapBuilderConfig c = looseConfig();
  c.max_heading_change_rad = deg2rad(45.0);
  auto b = SubmapBuilder::create(c);
  ASSERT_TRUE(b.ok());
  // Heading 170, 180, 190, ... deg: crosses the +-180 wrap; 50 deg from the base at scan 5.
  for (int k = 0; k < 7; ++k) {
    auto r = b->addScan(scanAt(poseAt(0.05 * k, 170.0 + 10.0 * k), 0.2 * (k + 1)));
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->has_value(), k == 5) << "scan " << k;
    if (k == 5) {
      EXPECT_EQ((*r)->reason, CloseReason::kHeadingChange);
      EXPECT_EQ((*r)->n_scans, 5U);
    }
  }
}

TEST(SubmapBuilder, GridIsInTheBaseFrameAndOdometryLinksBasePoses) {
  SubmapBuilderConfig c = looseConfig();
  c.max_scans = 30;
  auto b = SubmapBuilder::create(c);
  ASSERT_TRUE(b.ok());
  const test::SyntheticScene scene = test::SyntheticScene::pier();
  const auto orbit = test::orbitTrajectory(61, 5.5, -2.0);
  std::vector<ClosedSubmap> closed;
  for (std::size_t k = 0; k < orbit.size(); ++k) {
    auto r = b->addScan(scanAt(orbit[k], 0.2 * static_cast<double>(k + 1)));
    ASSERT_TRUE(r.ok()) << r.error().message;
    if (r->has_value()) closed.push_back(std::move(**r));
  }
  ASSERT_EQ(closed.size(), 2U);
  for (const ClosedSubmap& s : closed) {
    const std::size_t first = static_cast<std::size_t>(std::llround(1e-9 * s.first_stamp_ns / 0.2)) - 1;
    EXPECT_TRUE(s.T_world_base_odom.isApprox(orbit[first]));
    ASSERT_GT(s.grid->cloud().size(), 20U);
    // Every cloud point, mapped by the base pose, lies on a pier surface (within a voxel diagonal).
    for (const Eigen::Vector3d& p : s.grid->cloud().points) {
      EXPECT_LT(testing::distanceToPier(scene, s.T_world_base_odom * p), 0.35);
    }
  }
  EXPECT_FALSE(closed[0].has_previous);
  ASSERT_TRUE(closed[1].has_previous);
  EXPECT_TRUE(closed[1].odometry_from_previous.isApprox(
      planarOdometry(closed[0].T_world_base_odom, closed[1].T_world_base_odom)));
  const double dt = 30 * 0.2;
  EXPECT_NEAR(closed[1].odometry_covariance(0, 0), dt * c.odometry_cov_x_m2_per_s, 1e-12);
  EXPECT_NEAR(closed[1].odometry_covariance(1, 1), dt * c.odometry_cov_y_m2_per_s, 1e-12);
  EXPECT_NEAR(closed[1].odometry_covariance(2, 2), dt * c.odometry_cov_yaw_rad2_per_s, 1e-15);
}

TEST(SubmapBuilder, RejectsBadInputWithoutChangingState) {
  SubmapBuilderConfig c = looseConfig();
  c.max_scans = 3;
  auto b = SubmapBuilder::create(c);
  ASSERT_TRUE(b.ok());
  ASSERT_TRUE(b->addScan(scanAt(poseAt(0.0, 90.0), 1.0)).ok());
  ASSERT_TRUE(b->addScan(scanAt(poseAt(0.05, 90.0), 1.2)).ok());

  ScanInput nan_pose = scanAt(poseAt(0.1, 90.0), 1.4);
  nan_pose.T_world_vehicle_odom.translation().x() = std::numeric_limits<double>::quiet_NaN();
  auto r1 = b->addScan(nan_pose);
  ASSERT_FALSE(r1.ok());
  EXPECT_NE(r1.error().message.find("pose"), std::string::npos) << r1.error().message;

  auto r2 = b->addScan(scanAt(poseAt(0.1, 90.0), 1.2));  // same stamp as the previous scan
  ASSERT_FALSE(r2.ok());
  EXPECT_NE(r2.error().message.find("not after"), std::string::npos) << r2.error().message;

  ScanInput short_scan = scanAt(poseAt(0.1, 90.0), 1.4);
  short_scan.scan.range_m.pop_back();
  auto r3 = b->addScan(short_scan);
  ASSERT_FALSE(r3.ok());
  EXPECT_NE(r3.error().message.find("95 beams"), std::string::npos) << r3.error().message;

  ScanInput nan_range = scanAt(poseAt(0.1, 90.0), 1.4);
  nan_range.scan.range_m[3] = std::numeric_limits<float>::quiet_NaN();
  ASSERT_FALSE(b->addScan(nan_range).ok());
  ScanInput nan_depth = scanAt(poseAt(0.1, 90.0), 1.4);
  nan_depth.z_roll_pitch.x() = std::numeric_limits<double>::quiet_NaN();
  ASSERT_FALSE(b->addScan(nan_depth).ok());

  EXPECT_EQ(b->activeScanCount(), 2U);
  EXPECT_EQ(b->nextIndex(), 0);
  // The stream continues as if the bad scans never came: the third scan fills, the fourth closes.
  auto r4 = b->addScan(scanAt(poseAt(0.1, 90.0), 1.4));
  ASSERT_TRUE(r4.ok());
  EXPECT_FALSE(r4->has_value());
  auto r5 = b->addScan(scanAt(poseAt(0.15, 90.0), 1.6));
  ASSERT_TRUE(r5.ok());
  ASSERT_TRUE(r5->has_value());
  EXPECT_EQ((*r5)->n_scans, 3U);
}

TEST(SubmapBuilder, ConfigValidationNamesTheKey) {
  SubmapBuilderConfig c;
  EXPECT_TRUE(c.validate().ok());
  c.max_scans = 0;
  Status s = c.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("max_scans = 0"), std::string::npos) << s.error().message;
  c = {};
  c.odometry_cov_x_m2_per_s = std::numeric_limits<double>::quiet_NaN();
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("odometry_cov_x_m2_per_s"), std::string::npos);
  c = {};
  c.max_heading_change_rad = 4.0;
  ASSERT_FALSE(SubmapBuilder::create(c).ok());
}

}  // namespace
}  // namespace vog::slam
