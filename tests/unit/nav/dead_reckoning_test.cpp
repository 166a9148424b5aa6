// Dead reckoning against an analytic trajectory: exact without noise, within the predicted drift
// with seeded noise; PD0 sign and frames; rejection of bad samples; degraded states.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vog/nav/dead_reckoning.hpp"

namespace vog::nav {
namespace {

constexpr std::int64_t kMs = 1'000'000;

// A lawn-mower-free but curved test track: circle of radius 4 m at 0.2 m/s (HAUV speeds, thesis
// Table 4.2), depth 3 + 0.5 sin(wt) m, small roll/pitch oscillation. Heading follows the tangent.
struct Track {
  double radius_m = 4.0;
  double speed_mps = 0.2;
  double omega() const { return speed_mps / radius_m; }
  // World east/north position; starts at (0, 0) heading north, turning counter-clockwise (left).
  Eigen::Vector2d position(double t) const {
    const double a = omega() * t;
    return {radius_m * (std::cos(a) - 1.0), radius_m * std::sin(a)};
  }
  Eigen::Vector2d velocity(double t) const {
    const double a = omega() * t;
    return {-speed_mps * std::sin(a), speed_mps * std::cos(a)};
  }
  double depth(double t) const { return 3.0 + 0.5 * std::sin(0.05 * t); }
  double depthRate(double t) const { return 0.5 * 0.05 * std::cos(0.05 * t); }
  // NED heading: 0 north, clockwise positive; course of the velocity.
  double heading(double t) const {
    const Eigen::Vector2d v = velocity(t);
    return std::atan2(v.x(), v.y());
  }
  double roll(double t) const { return 0.05 * std::sin(0.7 * t); }
  double pitch(double t) const { return 0.04 * std::cos(0.3 * t); }
};

std::int64_t ns(double t) { return static_cast<std::int64_t>(std::llround(t * 1e9)); }

imu::ImuSample imuAt(const Track& tr, double t, double heading_noise = 0.0) {
  imu::ImuSample s;
  s.stamp_ns = ns(t);
  s.attitude = imu::ImuAttitude{tr.roll(t), tr.pitch(t), tr.heading(t) + heading_noise};
  return s;
}

// The DVL's instrument-frame velocity of the vehicle at t (default mount: x starboard, y forward, z up).
Eigen::Vector3d instrumentVelocity(const Track& tr, double t) {
  const Eigen::Matrix3d R_world_vehicle = worldFromNedAttitude(tr.roll(t), tr.pitch(t), tr.heading(t));
  const Eigen::Vector3d v_world(tr.velocity(t).x(), tr.velocity(t).y(), -tr.depthRate(t));
  const Eigen::Vector3d v_vehicle = R_world_vehicle.transpose() * v_world;  // forward, left, up
  return {-v_vehicle.y(), v_vehicle.x(), v_vehicle.z()};
}

dvl::DvlEnsemble pd0Ensemble(const Eigen::Vector3d& v_instrument, std::int64_t stamp_ns) {
  dvl::DvlEnsemble e;
  e.stamp_ns = stamp_ns;
  e.fixed.coordinate_transform = 0x08;
  e.fixed.coordinate_frame = dvl::CoordinateFrame::kInstrument;
  dvl::DvlBottomTrack bt;
  // PD0 reports the bottom's motion relative to the instrument: minus the vehicle's.
  for (int i = 0; i < 3; ++i) bt.velocity_mps[static_cast<std::size_t>(i)] = -v_instrument[i];
  bt.velocity_valid = {true, true, true, true};
  e.bottom_track = bt;
  return e;
}

struct RunResult {
  Eigen::Vector2d error_m;
  double sigma_m;
  NavSolution last;
};

// 400 s of the track: IMU 100 Hz, DVL 5 Hz, depth 4 Hz, all through the PD0 path.
RunResult run(const Track& tr, double dvl_sigma, double heading_sigma, std::uint64_t seed) {
  DeadReckoningConfig c;
  c.dvl_velocity_sigma_mps = dvl_sigma > 0 ? dvl_sigma : c.dvl_velocity_sigma_mps;
  c.heading_sigma_rad = heading_sigma > 0 ? heading_sigma : c.heading_sigma_rad;
  DeadReckoning dr(c);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const double duration_s = 400.0;
  for (int k = 0; k <= static_cast<int>(duration_s * 100); ++k) {
    const double t = k * 0.01;
    EXPECT_TRUE(dr.addImu(imuAt(tr, t, heading_sigma * n01(rng))).ok());
    if (k % 25 == 0) {
      depth::DepthSample d;
      d.stamp_ns = ns(t);
      d.depth_m = tr.depth(t);
      EXPECT_TRUE(dr.addDepth(d).ok());
    }
    if (k % 20 == 0) {
      // DVL stamped 3 ms after the IMU sample: attitude is interpolated, not taken as is.
      const double td = t + 0.003;
      Eigen::Vector3d v = instrumentVelocity(tr, td);
      for (int i = 0; i < 3; ++i) v[i] += dvl_sigma * n01(rng);
      Status s = dr.addDvl(pd0Ensemble(v, ns(td)));
      EXPECT_TRUE(s.ok()) << s.error().message;
    }
  }
  RunResult r;
  r.last = dr.solution(ns(duration_s));
  const Eigen::Vector2d truth = tr.position(duration_s + 0.003);
  r.error_m = r.last.T_world_vehicle.translation().head<2>() - truth;
  r.sigma_m = r.last.position_sigma_m;
  return r;
}

TEST(DeadReckoningTest, NoiselessTrackIsReproduced) {
  const Track tr;
  const RunResult r = run(tr, 0.0, 0.0, 1);
  // 80 m of curved path; trapezoid error for a 0.2 s step on a 4 m circle is O(v w^2 dt^2 T) ~ 1e-4 m.
  EXPECT_LT(r.error_m.norm(), 2e-3) << r.error_m.transpose();
  EXPECT_FALSE(r.last.degraded) << r.last.reason;
  EXPECT_TRUE(r.last.initialized);
  const double t = 400.0;
  EXPECT_NEAR(r.last.T_world_vehicle.translation().z(), -tr.depth(t), 1e-9);
  // Orientation: forward axis along the course, and roll/pitch as the IMU reports them.
  const Eigen::Vector3d forward = r.last.T_world_vehicle.linear().col(0);
  const Eigen::Vector2d course = tr.velocity(t).normalized();
  EXPECT_NEAR(forward.head<2>().normalized().dot(course), 1.0, 1e-9);
  EXPECT_TRUE(geometry::isValidPose(r.last.T_world_vehicle));
  EXPECT_EQ(r.last.dvl_used, 2001u);
}

TEST(DeadReckoningTest, NoisyTrackStaysWithinPredictedDrift) {
  const Track tr;
  const double dvl_sigma = 0.01;
  const double heading_sigma = 0.003;
  int within = 0;
  const int runs = 8;
  double sum_sq = 0.0;
  for (int i = 0; i < runs; ++i) {
    const RunResult r = run(tr, dvl_sigma, heading_sigma, 100 + static_cast<std::uint64_t>(i));
    ASSERT_GT(r.sigma_m, 0.0);
    // Each axis within 4 sigma of the prediction.
    EXPECT_LT(std::abs(r.error_m.x()), 4 * r.sigma_m) << "seed " << i;
    EXPECT_LT(std::abs(r.error_m.y()), 4 * r.sigma_m) << "seed " << i;
    within += (std::abs(r.error_m.x()) < 2 * r.sigma_m) ? 1 : 0;
    sum_sq += r.error_m.squaredNorm() / (2 * r.sigma_m * r.sigma_m);
  }
  // The model is not wildly pessimistic either: normalised mean squared error in [0.1, 3].
  const double nmse = sum_sq / runs;
  EXPECT_GT(nmse, 0.1);
  EXPECT_LT(nmse, 3.0);
  EXPECT_GE(within, runs / 2);
}

TEST(DeadReckoningTest, Pd0SignAndFramesAgree) {
  // Vehicle heading east (NED heading 90 deg), level, moving forward at 0.2 m/s for 10 s.
  auto feed = [](DeadReckoning& dr, auto&& addVelocity) {
    for (int k = 0; k <= 1000; ++k) {
      imu::ImuSample s;
      s.stamp_ns = k * 10 * kMs;
      s.attitude = imu::ImuAttitude{0.0, 0.0, M_PI / 2};
      ASSERT_TRUE(dr.addImu(s).ok());
      if (k % 20 == 0) {
        ASSERT_TRUE(addVelocity(dr, s.stamp_ns).ok());
      }
    }
  };
  DeadReckoning pd0;
  feed(pd0, [](DeadReckoning& dr, std::int64_t t) { return dr.addDvl(pd0Ensemble({0.0, 0.2, 0.0}, t)); });
  DeadReckoning ship;
  feed(ship, [](DeadReckoning& dr, std::int64_t t) {
    dvl::BottomVelocity v;
    v.stamp_ns = t;
    v.frame = dvl::CoordinateFrame::kShip;
    v.velocity_mps = {0.0, 0.2, 0.0};  // starboard, forward, up
    v.valid = true;
    return dr.addDvl(v);
  });
  DeadReckoning earth;
  feed(earth, [](DeadReckoning& dr, std::int64_t t) {
    dvl::BottomVelocity v;
    v.stamp_ns = t;
    v.frame = dvl::CoordinateFrame::kEarth;
    v.velocity_mps = {0.2, 0.0, 0.0};  // east, north, up
    v.valid = true;
    return dr.addDvl(v);
  });
  for (const DeadReckoning* dr : {&pd0, &ship, &earth}) {
    const Eigen::Vector3d p = dr->solution(10 * 1000 * kMs).T_world_vehicle.translation();
    EXPECT_NEAR(p.x(), 2.0, 1e-9);  // 10 s east at 0.2 m/s
    EXPECT_NEAR(p.y(), 0.0, 1e-9);
  }
}

TEST(DeadReckoningTest, BadSamplesAreRejectedAndChangeNothing) {
  DeadReckoning dr;
  imu::ImuSample s;
  s.stamp_ns = 0;
  s.attitude = imu::ImuAttitude{0, 0, 0};
  ASSERT_TRUE(dr.addImu(s).ok());
  ASSERT_TRUE(dr.addDvl(pd0Ensemble({0, 0.1, 0}, 1 * kMs)).ok());
  const Eigen::Vector3d before = dr.solution(2 * kMs).T_world_vehicle.translation();

  dvl::DvlEnsemble bad_beam = pd0Ensemble({0, 0.1, 0}, 50 * kMs);
  bad_beam.bottom_track->velocity_valid[1] = false;
  Status st = dr.addDvl(bad_beam);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("component 2 is bad"), std::string::npos) << st.error().message;

  dvl::DvlEnsemble beam = pd0Ensemble({0, 0.1, 0}, 50 * kMs);
  beam.fixed.coordinate_frame = dvl::CoordinateFrame::kBeam;
  EXPECT_FALSE(dr.addDvl(beam).ok());
  dvl::DvlEnsemble no_bt = pd0Ensemble({0, 0.1, 0}, 50 * kMs);
  no_bt.bottom_track.reset();
  EXPECT_FALSE(dr.addDvl(no_bt).ok());
  dvl::DvlEnsemble disagree = pd0Ensemble({0, 0.1, 0}, 50 * kMs);
  disagree.bottom_track->velocity_mps[3] = 0.5;
  st = dr.addDvl(disagree);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("error velocity"), std::string::npos);
  dvl::DvlEnsemble fast = pd0Ensemble({0, 30.0, 0}, 50 * kMs);
  EXPECT_FALSE(dr.addDvl(fast).ok());
  dvl::DvlEnsemble nan = pd0Ensemble({0, std::nan(""), 0}, 50 * kMs);
  EXPECT_FALSE(dr.addDvl(nan).ok());
  EXPECT_FALSE(dr.addDvl(pd0Ensemble({0, 0.1, 0}, 1 * kMs)).ok());  // not after the previous
  // 0.5 s after the last attitude: no attitude to rotate with.
  st = dr.addDvl(pd0Ensemble({0, 0.1, 0}, 600 * kMs));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("imu"), std::string::npos) << st.error().message;

  imu::ImuSample faulty = s;
  faulty.stamp_ns = 10 * kMs;
  faulty.status = 0x4;
  EXPECT_FALSE(dr.addImu(faulty).ok());
  imu::ImuSample no_att;
  no_att.stamp_ns = 11 * kMs;
  EXPECT_FALSE(dr.addImu(no_att).ok());
  depth::DepthSample deep;
  deep.stamp_ns = 5 * kMs;
  deep.depth_m = std::nan("");
  EXPECT_FALSE(dr.addDepth(deep).ok());

  const NavSolution after = dr.solution(2 * kMs);
  EXPECT_EQ(after.T_world_vehicle.translation(), before);
  EXPECT_EQ(after.dvl_rejected, 8u);
  EXPECT_EQ(after.imu_rejected, 2u);
  EXPECT_EQ(after.depth_rejected, 1u);
  EXPECT_EQ(after.dvl_used, 1u);
}

TEST(DeadReckoningTest, StaleAndMissingSensorsDegradeWithReason) {
  DeadReckoning dr;
  NavSolution s0 = dr.solution(0);
  EXPECT_TRUE(s0.degraded);
  EXPECT_FALSE(s0.initialized);
  EXPECT_NE(s0.reason.find("no imu data yet"), std::string::npos);
  EXPECT_NE(s0.reason.find("no dvl data yet"), std::string::npos);
  EXPECT_NE(s0.reason.find("no depth data yet"), std::string::npos);

  for (int k = 0; k <= 300; ++k) {
    imu::ImuSample s;
    s.stamp_ns = k * 10 * kMs;
    s.attitude = imu::ImuAttitude{0, 0, 0};
    ASSERT_TRUE(dr.addImu(s).ok());
    if (k % 25 == 0) {
      depth::DepthSample d;
      d.stamp_ns = s.stamp_ns;
      d.depth_m = 2.0;
      ASSERT_TRUE(dr.addDepth(d).ok());
    }
    // The DVL loses bottom lock after 1 s.
    if (k % 20 == 0 && k <= 100) {
      ASSERT_TRUE(dr.addDvl(pd0Ensemble({0, 0.1, 0}, s.stamp_ns)).ok());
    }
  }
  const NavSolution healthy = dr.solution(1500 * kMs);
  EXPECT_FALSE(healthy.degraded) << healthy.reason;
  const NavSolution stale = dr.solution(3000 * kMs);
  EXPECT_TRUE(stale.degraded);
  EXPECT_NE(stale.reason.find("dvl stale (2 s)"), std::string::npos) << stale.reason;
  EXPECT_EQ(stale.reason.find("imu"), std::string::npos) << stale.reason;
  // Position held where the last accepted velocity left it: 1 s north at 0.1 m/s.
  EXPECT_NEAR(stale.T_world_vehicle.translation().y(), 0.1, 1e-9);
  EXPECT_NEAR(stale.T_world_vehicle.translation().z(), -2.0, 1e-12);
}

// Poses between DVL samples (a sonar ping): on the noiseless circle, poseAt() at the midpoint of
// two DVL samples is within the straight-line extrapolation error of the truth, with the attitude
// interpolated between IMU samples; stale or missing sensors are named.
TEST(DeadReckoningTest, PoseAtAStampBetweenSamplesFollowsTheTrack) {
  const Track tr;
  DeadReckoning dr;
  EXPECT_NE(dr.poseAt(0).error().message.find("no dvl data yet"), std::string::npos);
  double worst_m = 0.0, worst_rad = 0.0;
  for (int k = 0; k <= 2000; ++k) {
    const double t = k * 0.01;
    ASSERT_TRUE(dr.addImu(imuAt(tr, t)).ok());
    if (k % 25 == 0) {
      depth::DepthSample d;
      d.stamp_ns = ns(t);
      d.depth_m = tr.depth(t);
      ASSERT_TRUE(dr.addDepth(d).ok());
    }
    if (k % 20 == 0) {
      ASSERT_TRUE(dr.addDvl(pd0Ensemble(instrumentVelocity(tr, t), ns(t))).ok());
    }
    if (k % 20 == 10 && k > 100) {
      // 0.1 s after the DVL sample, 5 ms after the newest IMU sample (held within imu_max_gap_s).
      const double tp = t + 0.005;
      auto T = dr.poseAt(ns(tp));
      ASSERT_TRUE(T.ok()) << T.error().message;
      worst_m = std::max(worst_m, (T->translation().head<2>() - tr.position(tp)).norm());
      const Eigen::Matrix3d R_truth = worldFromNedAttitude(tr.roll(tp), tr.pitch(tp), tr.heading(tp));
      worst_rad = std::max(worst_rad, Eigen::AngleAxisd(R_truth.transpose() * T->linear()).angle());
      EXPECT_NEAR(T->translation().z(), -tr.depth(tp), 0.01);
    }
  }
  // Extrapolating 0.105 s along the tangent: v^2 dt^2 / (2 r) is under 0.1 mm; the attitude is held 5 ms
  // (the heading turns 0.05 rad/s).
  EXPECT_LT(worst_m, 2e-3);
  EXPECT_LT(worst_rad, 1e-3);
  // A stamp beyond the DVL timeout (1 s) is refused, naming the DVL.
  auto late = dr.poseAt(ns(20.0 + 1.5));
  ASSERT_FALSE(late.ok());
  EXPECT_NE(late.error().message.find("dvl"), std::string::npos) << late.error().message;
}

TEST(DeadReckoningTest, ConfigValidateNamesKey) {
  DeadReckoningConfig c;
  EXPECT_TRUE(c.validate().ok());
  c.dvl_timeout_s = -1;
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("nav.dvl_timeout_s"), std::string::npos);
  c.dvl_timeout_s = 1;
  c.dvl_mount_yaw_rad = std::nan("");
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("dvl_mount_yaw_rad"), std::string::npos);
}

TEST(DeadReckoningTest, NedToWorldConversion) {
  // Heading north, level: vehicle forward = world north (+y), vehicle left = west (-x), up = up.
  const Eigen::Matrix3d R = worldFromNedAttitude(0, 0, 0);
  EXPECT_TRUE(R.col(0).isApprox(Eigen::Vector3d(0, 1, 0)));
  EXPECT_TRUE(R.col(1).isApprox(Eigen::Vector3d(-1, 0, 0)));
  EXPECT_TRUE(R.col(2).isApprox(Eigen::Vector3d(0, 0, 1)));
  // Nose up (positive NED pitch) raises the forward axis.
  EXPECT_GT(worldFromNedAttitude(0, 0.3, 0).col(0).z(), 0.2);
  // Positive NED roll puts the starboard side down, so the left axis rises.
  EXPECT_GT(worldFromNedAttitude(0.3, 0, 0).col(1).z(), 0.2);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
}

}  // namespace
}  // namespace vog::nav
