// ICP : flat wall (degenerate along the wall), corner (full rank), baseline 2D
// point-to-point with the thesis Alg. 6 acceptance checks, and bad input. Clouds are sampled on
// planes with normals, with seeded noise.
#include "vog/geometry/sonar.hpp"
#include "vog/slam/icp.hpp"
#include "vog/slam/pose_graph.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

namespace vog::slam {
namespace {

using geometry::deg2rad;
using geometry::PointCloud;
using geometry::Pose3;

struct Plane {
  Eigen::Vector3d origin;
  Eigen::Vector3d u;  // in-plane axes (unit, orthogonal)
  Eigen::Vector3d v;
  double u_len, v_len;
};

// Samples planes (in the target frame) on a jittered grid, range noise along the normal, normals
// perturbed by normal_noise_rad; then expresses the cloud in the frame `T_frame_target`.
PointCloud samplePlanes(const std::vector<Plane>& planes, const Pose3& T_frame_target, double spacing_m, double noise_m,
                        double normal_noise_rad, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> jitter(-0.5, 0.5);
  PointCloud cloud;
  for (const Plane& pl : planes) {
    const Eigen::Vector3d n = pl.u.cross(pl.v).normalized();
    for (double a = 0.0; a <= pl.u_len; a += spacing_m) {
      for (double b = 0.0; b <= pl.v_len; b += spacing_m) {
        const Eigen::Vector3d p = pl.origin + (a + spacing_m * jitter(rng)) * pl.u +
                                  (b + spacing_m * jitter(rng)) * pl.v + noise_m * g(rng) * n;
        const Eigen::Vector3d nn = (n + normal_noise_rad * Eigen::Vector3d(g(rng), g(rng), g(rng))).normalized();
        cloud.points.push_back(T_frame_target * p);
        cloud.normals.push_back(T_frame_target.linear() * nn);
      }
    }
  }
  return cloud;
}

// A vertical wall at x = 5 in the target frame facing the origin (normal -x), 6 m long, 2 m high.
Plane wallX() { return {{5, -3, -3}, {0, 0, 1}, {0, 1, 0}, 2.0, 6.0}; }
// A second wall at y = 4 (normal -y).
Plane wallY() { return {{-1, 4, -3}, {1, 0, 0}, {0, 0, 1}, 6.0, 2.0}; }
// The floor at z = -3.5 (normal +z).
Plane floorZ() { return {{-1, -3, -3.5}, {1, 0, 0}, {0, 1, 0}, 6.0, 7.0}; }

const Pose3 kTruth = geometry::poseFromXyzRpy(0.4, 0.8, 0.0, 0.0, 0.0, deg2rad(4.0));  // T_target_source

struct WallPair {
  PointCloud target, source;
};

WallPair makeClouds(const std::vector<Plane>& planes, double normal_noise_rad) {
  WallPair w;
  w.target = samplePlanes(planes, Pose3::Identity(), 0.1, 0.01, normal_noise_rad, 11);
  w.source = samplePlanes(planes, kTruth.inverse(), 0.1, 0.01, normal_noise_rad, 12);
  return w;
}

// Two submaps overlap only in part: a face only the source saw, 0.5 m behind a face both saw, finds
// its nearest target points on that face. Within a fixed 1 m bound it pulls the registration by
// about its share of the points; with the bound shrinking to 0.3 m it drops out and the fitness
// counts the overlap only.
TEST(DegeneracyAwareIcp, ShrinkingBoundIgnoresAFaceOnlyTheSourceSaw) {
  const std::vector<Plane> both = {wallX(), wallY()};
  const Plane behind{{5.5, -3, -3}, {0, 0, 1}, {0, 1, 0}, 2.0, 2.0};
  const PointCloud target = samplePlanes(both, Pose3::Identity(), 0.1, 0.01, 0.02, 21);
  PointCloud source = samplePlanes(both, kTruth.inverse(), 0.1, 0.01, 0.02, 22);
  const PointCloud extra = samplePlanes({behind}, kTruth.inverse(), 0.1, 0.01, 0.02, 23);
  const std::size_t n_shared = source.size();
  source.points.insert(source.points.end(), extra.points.begin(), extra.points.end());
  source.normals.insert(source.normals.end(), extra.normals.begin(), extra.normals.end());
  Vector6d x0 = toXyzRpy(kTruth);
  x0(kX) += 0.1;
  x0(kY) -= 0.1;
  x0(kYaw) += deg2rad(1.0);
  const Vector6d truth = toXyzRpy(kTruth);

  PointToPlaneConfig fixed;
  fixed.min_correspondence_distance_m = fixed.max_correspondence_distance_m;
  const auto biased = icpPointToPlane(source, target, fromXyzRpy(x0), fixed);
  ASSERT_TRUE(biased.ok()) << biased.error().message;
  EXPECT_GT(std::abs(toXyzRpy(biased->T_target_source)(kX) - truth(kX)), 0.05);
  EXPECT_EQ(biased->n_correspondences, source.size());

  const auto shrunk = icpPointToPlane(source, target, fromXyzRpy(x0), PointToPlaneConfig{});
  ASSERT_TRUE(shrunk.ok()) << shrunk.error().message;
  EXPECT_TRUE(shrunk->converged);
  const Vector6d x = toXyzRpy(shrunk->T_target_source);
  EXPECT_NEAR(x(kX), truth(kX), 0.01);
  EXPECT_NEAR(x(kY), truth(kY), 0.01);
  EXPECT_NEAR(x(kYaw), truth(kYaw), deg2rad(0.1));
  // Fitness and correspondences within the final 0.3 m: the shared faces only.
  EXPECT_LE(shrunk->n_correspondences, n_shared + n_shared / 50);
  EXPECT_GE(shrunk->n_correspondences, n_shared - n_shared / 50);
  EXPECT_LT(shrunk->fitness_m2, 0.01);
  EXPECT_GT(biased->fitness_m2, 5.0 * shrunk->fitness_m2);
}

// Test (1): a single flat wall.
TEST(DegeneracyAwareIcp, FlatWallCorrectsNormalAndYawKeepsAlongWallFromOdometry) {
  const WallPair w = makeClouds({wallX()}, 0.05);
  Vector6d x_odom = toXyzRpy(kTruth);
  x_odom(kX) += 0.15;          // normal offset
  x_odom(kY) += 0.30;          // along the wall: unobservable
  x_odom(kYaw) += deg2rad(2);  // heading
  const Pose3 T_odom = fromXyzRpy(x_odom);

  PointToPlaneConfig cfg;
  auto degen = icpPointToPlane(w.source, w.target, T_odom, cfg);
  ASSERT_TRUE(degen.ok()) << degen.error().message;
  EXPECT_TRUE(degen->converged);
  const Vector6d xd = toXyzRpy(degen->T_target_source);
  const Vector6d xt = toXyzRpy(kTruth);
  EXPECT_NEAR(xd(kX), xt(kX), 0.02);
  EXPECT_NEAR(xd(kYaw), xt(kYaw), deg2rad(0.5));
  EXPECT_NEAR(xd(kY), x_odom(kY), 0.01) << "along-wall component must stay at odometry";
  EXPECT_NEAR(xd(kZ), x_odom(kZ), 1e-12);  // planar mode holds z, roll, pitch

  // The well-conditioned basis has rank 2 and spans the normal (x) and yaw, not y.
  ASSERT_EQ(degen->V_u.rows(), 2);
  const Matrix6d P = degen->V_u.transpose() * degen->V_u;  // projector on span(V_u)
  EXPECT_GT((P * Vector6d::Unit(kX)).norm(), 0.99);
  EXPECT_GT((P * Vector6d::Unit(kYaw)).norm(), 0.99);
  EXPECT_LT((P * Vector6d::Unit(kY)).norm(), 0.05);

  // Plain point-to-plane ICP (lambda_min = 0) steps along the noise-driven along-wall direction too.
  PointToPlaneConfig plain_cfg;
  plain_cfg.degeneracy_aware = false;
  auto plain = icpPointToPlane(w.source, w.target, T_odom, plain_cfg);
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  const Vector6d xp = toXyzRpy(plain->T_target_source);
  // (How far it slides depends on the noise and on the compiler's rounding: only that it leaves odometry.)
  EXPECT_GT(std::abs(xp(kY) - x_odom(kY)), std::abs(xd(kY) - x_odom(kY)) + 1e-3)
      << "plain ICP y " << xp(kY) << ", degeneracy-aware y " << xd(kY) << ", odometry y " << x_odom(kY);
  EXPECT_EQ(plain->V_u.rows(), 3);  // it treats every direction as constrained

  // Partial factor (thesis Alg. 8): rank 2, measurement V_u x_icp, covariance V_u Cov V_u^T.
  auto closure = makePartialLoopClosure(degen->V_u, xd, degen->covariance);
  ASSERT_TRUE(closure.ok()) << closure.error().message;
  EXPECT_EQ(closure->rank(), 2);
  EXPECT_TRUE(closure->measurement.isApprox(degen->V_u * xd));
  const Eigen::MatrixXd expected_cov =
      (cfg.sigma_point_m * cfg.sigma_point_m) * degen->eigenvalues_u.cwiseInverse().asDiagonal().toDenseMatrix();
  EXPECT_TRUE(closure->covariance.isApprox(expected_cov, 1e-9));
}

// The unique-optimum probe as measured in daemon/slam/README.md (off by default).
PointToPlaneConfig withProbe() {
  PointToPlaneConfig c;
  c.probe_steps = 3;
  return c;
}

// A long wall with noisy normals: their noise adds information along the wall that grows with the
// point count, so the eigenvalue rule alone keeps the slide; the unique-optimum probe finds no cost
// for a shift along the wall (points shifted past its ends land where the target saw nothing) and
// drops it.
TEST(DegeneracyAwareIcp, ProbeDropsTheSlideAlongAWallWhoseNoisyNormalsPassTheEigenvalueRule) {
  const WallPair w = makeClouds({wallX()}, 0.2);
  Vector6d x_odom = toXyzRpy(kTruth);
  x_odom(kX) += 0.1;
  x_odom(kY) += 0.3;
  PointToPlaneConfig no_probe;
  no_probe.probe_steps = 0;
  auto unprobed = icpPointToPlane(w.source, w.target, fromXyzRpy(x_odom), no_probe);
  ASSERT_TRUE(unprobed.ok()) << unprobed.error().message;
  ASSERT_EQ(unprobed->V_u.rows(), 3) << "the eigenvalue rule should keep the slide for this test to mean anything";
  EXPECT_EQ(unprobed->ambiguous_directions, 0);

  const TargetKnown seen = [](const Eigen::Vector3d& p) {  // the wall's slab and the water in front of it
    return p.x() > 3.0 && p.x() < 5.2 && p.y() > -3.0 && p.y() < 3.0 && p.z() > -3.0 && p.z() < -1.0;
  };
  auto probed = icpPointToPlane(w.source, w.target, fromXyzRpy(x_odom), withProbe(), seen);
  ASSERT_TRUE(probed.ok()) << probed.error().message;
  EXPECT_EQ(probed->T_target_source.matrix(), unprobed->T_target_source.matrix());  // the same registration
  ASSERT_EQ(probed->V_u.rows(), 2);
  EXPECT_EQ(probed->ambiguous_directions, 1);
  const Matrix6d P = probed->V_u.transpose() * probed->V_u;
  EXPECT_LT((P * Vector6d::Unit(kY)).norm(), 0.2) << "the slide along the wall must not be asserted";
  EXPECT_GT((P * Vector6d::Unit(kX)).norm(), 0.95);
  // The covariance follows the rows kept.
  EXPECT_TRUE((probed->V_u * probed->covariance * probed->V_u.transpose())
                  .isApprox((no_probe.sigma_point_m * no_probe.sigma_point_m) *
                                probed->eigenvalues_u.cwiseInverse().asDiagonal().toDenseMatrix(),
                            1e-9));
}

// The wall with a small box on it (0.6 x 0.5 m, 0.3 m proud), whose sides pin the slide.
std::vector<Plane> wallWithABox() {
  const Plane front{{4.7, 0.0, -2.5}, {0, 0, 1}, {0, 1, 0}, 0.5, 0.6};   // normal -x, facing the origin
  const Plane side_a{{4.7, 0.0, -2.5}, {1, 0, 0}, {0, 0, 1}, 0.3, 0.5};  // y = 0, normal -y
  const Plane side_b{{4.7, 0.6, -2.5}, {0, 0, 1}, {1, 0, 0}, 0.5, 0.3};  // y = 0.6, normal +y
  return {wallX(), front, side_a, side_b};
}

// The same wall with the box: the probe keeps the slide.
TEST(DegeneracyAwareIcp, ProbeKeepsTheSlideAFeatureOnTheWallPins) {
  const WallPair w = makeClouds(wallWithABox(), 0.2);
  Vector6d x0 = toXyzRpy(kTruth);
  x0(kX) += 0.1;
  x0(kY) += 0.15;
  auto r = icpPointToPlane(w.source, w.target, fromXyzRpy(x0), withProbe());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->ambiguous_directions, 0);
  ASSERT_EQ(r->V_u.rows(), 3);
  EXPECT_NEAR(toXyzRpy(r->T_target_source)(kY), toXyzRpy(kTruth)(kY), 0.03);
}

PointToPlaneConfig withNoiseFloor() {
  PointToPlaneConfig c;
  c.normal_noise_floor = true;
  return c;
}

// The same long wall with noisy normals: the noise floor takes off the information their noise adds
// along the wall (estimated from the angles between corresponding normals), so the slide is not
// well-conditioned, the registration does not step along it and the factor does not assert it; the
// normal and the heading, which the wall's points constrain by moving across it, stay.
TEST(DegeneracyAwareIcp, NoiseFloorDropsTheSlideAlongAWallWhoseNoisyNormalsPassTheEigenvalueRule) {
  const WallPair w = makeClouds({wallX()}, 0.2);
  Vector6d x_odom = toXyzRpy(kTruth);
  x_odom(kX) += 0.1;
  x_odom(kY) += 0.3;
  x_odom(kYaw) += deg2rad(1.5);
  const auto without = icpPointToPlane(w.source, w.target, fromXyzRpy(x_odom), PointToPlaneConfig{});
  ASSERT_TRUE(without.ok()) << without.error().message;
  ASSERT_EQ(without->V_u.rows(), 3) << "the eigenvalue rule should keep the slide for this test to mean anything";

  const auto with = icpPointToPlane(w.source, w.target, fromXyzRpy(x_odom), withNoiseFloor());
  ASSERT_TRUE(with.ok()) << with.error().message;
  EXPECT_TRUE(with->converged);
  ASSERT_EQ(with->V_u.rows(), 2);
  const Matrix6d P = with->V_u.transpose() * with->V_u;
  EXPECT_LT((P * Vector6d::Unit(kY)).norm(), 0.1) << "the slide along the wall must not be asserted";
  EXPECT_GT((P * Vector6d::Unit(kX)).norm(), 0.99);
  EXPECT_GT((P * Vector6d::Unit(kYaw)).norm(), 0.99);
  const Vector6d x = toXyzRpy(with->T_target_source);
  const Vector6d truth = toXyzRpy(kTruth);
  EXPECT_NEAR(x(kY), x_odom(kY), 0.01) << "along the wall the estimate stays at the initial guess";
  EXPECT_NEAR(x(kX), truth(kX), 0.02);
  EXPECT_NEAR(x(kYaw), truth(kYaw), deg2rad(0.5));
  EXPECT_GT(std::abs(toXyzRpy(without->T_target_source)(kY) - x_odom(kY)), std::abs(x(kY) - x_odom(kY)) + 1e-3)
      << "without the floor the registration steps along the noise-driven slide";
}

// The wall with the small box on it and the same noisy normals: the box's sides move across their
// surface along the wall, so the slide keeps its information above the floor and is recovered.
TEST(DegeneracyAwareIcp, NoiseFloorKeepsTheSlideAFeatureOnTheWallPins) {
  const WallPair w = makeClouds(wallWithABox(), 0.2);
  Vector6d x0 = toXyzRpy(kTruth);
  x0(kX) += 0.1;
  x0(kY) += 0.15;
  const auto r = icpPointToPlane(w.source, w.target, fromXyzRpy(x0), withNoiseFloor());
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->V_u.rows(), 3);
  EXPECT_NEAR(toXyzRpy(r->T_target_source)(kY), toXyzRpy(kTruth)(kY), 0.03);

  // The floor is estimated from the normals' agreement, so it needs the normals check.
  PointToPlaneConfig unchecked = withNoiseFloor();
  unchecked.max_normal_angle_rad = std::numbers::pi;
  const Status s = unchecked.validate();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("normal_noise_floor"), std::string::npos) << s.error().message;
}

// Test (2): a corner; full rank; truth recovered within 2 cm / 0.5 deg from 0.3 m / 3 deg.
TEST(DegeneracyAwareIcp, CornerIsFullRankAndRecoversTruth) {
  const WallPair w = makeClouds({wallX(), wallY()}, 0.02);
  const Vector6d xt = toXyzRpy(kTruth);
  for (const double sign : {1.0, -1.0}) {
    Vector6d x0 = xt;
    x0(kX) += sign * 0.18;
    x0(kY) -= sign * 0.24;  // |(0.18, 0.24)| = 0.3 m
    x0(kYaw) += sign * deg2rad(3.0);
    auto r = icpPointToPlane(w.source, w.target, fromXyzRpy(x0), {});
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(r->converged);
    EXPECT_EQ(r->V_u.rows(), 3);
    EXPECT_LT(geometry::translationDistance(r->T_target_source, kTruth), 0.02);
    EXPECT_LT(geometry::rotationAngle(r->T_target_source, kTruth), deg2rad(0.5));
    EXPECT_LT(r->fitness_m2, 0.01);
  }
}

// Half of a post (vertical cylinder of radius r, centre (cx, cy) in the target frame): the half whose
// outward normals point towards `towards_x` (-1: the half a sonar on the -x side sees, +1: the other),
// expressed in the frame T_frame_target.
PointCloud postHalf(double cx, double cy, double r, double towards_x, const Pose3& T_frame_target, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 0.005);
  PointCloud cloud;
  for (double a = -0.5 * std::numbers::pi; a <= 0.5 * std::numbers::pi; a += 0.03) {
    const Eigen::Vector3d n(towards_x * std::cos(a), std::sin(a), 0.0);
    for (double z = -3.0; z <= -1.0; z += 0.01) {
      const Eigen::Vector3d p = Eigen::Vector3d(cx, cy, z) + (r + g(rng)) * n;
      cloud.points.push_back(T_frame_target * p);
      cloud.normals.push_back(T_frame_target.linear() * n);
    }
  }
  return cloud;
}

void append(PointCloud& to, const PointCloud& from) {
  to.points.insert(to.points.end(), from.points.begin(), from.points.end());
  to.normals.insert(to.normals.end(), from.normals.begin(), from.normals.end());
}

// Normals agreement: the target saw a post's near half from -x, the source its far half from +x (densely,
// as a sonar sees a piling it passes close by), both with a corner that pins the truth. The far half's points lie
// within the bound of the near half's (2 r apart) and, paired with them, pull the registration by a share of 2 r; their
// normals point the other way, so with the check they find no partner and the corner alone decides.
TEST(DegeneracyAwareIcp, NormalsAgreementKeepsTheTwoSidesOfAPostApart) {
  WallPair w = makeClouds({wallX(), wallY()}, 0.02);
  append(w.target, postHalf(2.0, 1.0, 0.14, -1.0, Pose3::Identity(), 31));
  append(w.source, postHalf(2.0, 1.0, 0.14, +1.0, kTruth.inverse(), 32));
  Vector6d x0 = toXyzRpy(kTruth);
  x0(kX) += 0.1;
  x0(kY) -= 0.1;
  PointToPlaneConfig any;
  any.max_normal_angle_rad = std::numbers::pi;  // no check
  const auto paired = icpPointToPlane(w.source, w.target, fromXyzRpy(x0), any);
  ASSERT_TRUE(paired.ok()) << paired.error().message;
  const double bias = geometry::translationDistance(paired->T_target_source, kTruth);
  EXPECT_GT(bias, 0.01);
  PointToPlaneConfig agreeing;
  agreeing.max_normal_angle_rad = deg2rad(45.0);
  const auto kept_apart = icpPointToPlane(w.source, w.target, fromXyzRpy(x0), agreeing);
  ASSERT_TRUE(kept_apart.ok()) << kept_apart.error().message;
  EXPECT_LT(geometry::translationDistance(kept_apart->T_target_source, kTruth), 0.25 * bias);
  EXPECT_LT(geometry::rotationAngle(kept_apart->T_target_source, kTruth), deg2rad(0.3));

  // The check needs the source's normals, and an angle in (0, pi].
  PointCloud bare = w.source;
  bare.normals.clear();
  const auto refused = icpPointToPlane(bare, w.target, fromXyzRpy(x0), agreeing);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("source"), std::string::npos) << refused.error().message;
  agreeing.max_normal_angle_rad = 0.0;
  EXPECT_FALSE(agreeing.validate().ok());
}

// A face x = x_face, y in [-3, 3], z in [-3, -1] on an unjittered 0.1 m grid (the same y, z for every
// face, unlike samplePlanes' jittered one), normals along `facing_x`, with range noise; in `T_frame_target`.
PointCloud gridFace(double x_face, double facing_x, const Pose3& T_frame_target, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 0.005);
  PointCloud cloud;
  for (int i = 0; i <= 60; ++i) {
    for (int j = 0; j <= 20; ++j) {
      const Eigen::Vector3d p(x_face + g(rng), -3.0 + 0.1 * i, -3.0 + 0.1 * j);
      cloud.points.push_back(T_frame_target * p);
      cloud.normals.push_back(T_frame_target.linear() * Eigen::Vector3d(facing_x, 0, 0));
    }
  }
  return cloud;
}

// The probe pairs points by the registration's rule. A slab as thick as the probe's first shift: the
// target saw its near face (x = 5, from -x) and its far face (from +x), the source the near face only,
// with a wall that pins y and yaw. Shifted across the slab by that much, the source's face lies on
// the target's far face: paired with the nearest point, the shift costs nothing and the probe drops
// the direction the near face pins; with the normals check the far face's points are no partners
// (they were seen from the other side), the shift costs, and the direction stays.
TEST(DegeneracyAwareIcp, ProbePairsPointsByTheNormalsCheck) {
  PointToPlaneConfig checked = withProbe();
  ASSERT_LT(checked.max_normal_angle_rad, std::numbers::pi) << "the normals check is on by default";
  const double thickness = checked.probe_max_shift_m / checked.probe_steps;
  // No turn between the two, and the faces centred on the source's x axis: x is an eigenvector of its
  // own (the wall, sampled more sparsely, pins y and yaw), so the probe's first shift is `thickness`.
  const Pose3 truth = geometry::poseFromXyzRpy(0.4, 0.0, 0.0, 0.0, 0.0, 0.0);
  PointCloud target = samplePlanes({wallY()}, Pose3::Identity(), 0.2, 0.01, 0.02, 51);
  append(target, gridFace(5.0, -1.0, Pose3::Identity(), 52));
  append(target, gridFace(5.0 + thickness, +1.0, Pose3::Identity(), 53));
  PointCloud source = samplePlanes({wallY()}, truth.inverse(), 0.2, 0.01, 0.02, 54);
  append(source, gridFace(5.0, -1.0, truth.inverse(), 55));

  PointToPlaneConfig unchecked = checked;
  unchecked.max_normal_angle_rad = std::numbers::pi;
  const auto nearest = icpPointToPlane(source, target, truth, unchecked);
  ASSERT_TRUE(nearest.ok()) << nearest.error().message;
  EXPECT_EQ(nearest->ambiguous_directions, 1);
  EXPECT_EQ(nearest->V_u.rows(), 2);

  const auto agreeing = icpPointToPlane(source, target, truth, checked);
  ASSERT_TRUE(agreeing.ok()) << agreeing.error().message;
  EXPECT_EQ(agreeing->ambiguous_directions, 0);
  ASSERT_EQ(agreeing->V_u.rows(), 3);
  EXPECT_LT(geometry::translationDistance(agreeing->T_target_source, truth), 0.01);
}

// A thin plate: the target saw its near face (x = 5, from -x) and its far face 0.12 m behind (from
// +x), the source the near face only, with a wall that pins y and yaw; the estimate starts 0.1 m off
// across the plate, so each near-face source point's nearest target point lies on the far face.
// Without the check they pair and the result ends on the far face; with the check and the nearest
// point only they find no partner and nothing corrects the offset; the nearest agreeing point among
// the nearest eight is on the near face, and the result is the truth.
TEST(DegeneracyAwareIcp, NormalsAgreementFindsTheAgreeingFaceBehindTheNearestPoint) {
  PointCloud target = samplePlanes({wallY()}, Pose3::Identity(), 0.1, 0.01, 0.02, 41);
  append(target, gridFace(5.0, -1.0, Pose3::Identity(), 42));
  append(target, gridFace(5.12, +1.0, Pose3::Identity(), 43));
  PointCloud source = samplePlanes({wallY()}, kTruth.inverse(), 0.1, 0.01, 0.02, 44);
  append(source, gridFace(5.0, -1.0, kTruth.inverse(), 45));
  Vector6d x0 = toXyzRpy(kTruth);
  x0(kX) += 0.1;
  const auto across_error = [](const Pose3& T) { return std::abs(T.translation().x() - kTruth.translation().x()); };

  PointToPlaneConfig any;
  any.max_normal_angle_rad = std::numbers::pi;  // no check
  const auto paired = icpPointToPlane(source, target, fromXyzRpy(x0), any);
  ASSERT_TRUE(paired.ok()) << paired.error().message;
  EXPECT_GT(across_error(paired->T_target_source), 0.05);

  PointToPlaneConfig nearest_only;
  nearest_only.max_normal_angle_rad = deg2rad(45.0);
  nearest_only.normal_search_neighbours = 1;
  const auto stuck = icpPointToPlane(source, target, fromXyzRpy(x0), nearest_only);
  ASSERT_TRUE(stuck.ok()) << stuck.error().message;
  EXPECT_GT(across_error(stuck->T_target_source), 0.05);

  PointToPlaneConfig searching = nearest_only;
  searching.normal_search_neighbours = PointToPlaneConfig{}.normal_search_neighbours;
  ASSERT_GT(searching.normal_search_neighbours, 1);
  const auto found = icpPointToPlane(source, target, fromXyzRpy(x0), searching);
  ASSERT_TRUE(found.ok()) << found.error().message;
  EXPECT_LT(across_error(found->T_target_source), 0.01);
  EXPECT_LT(geometry::rotationAngle(found->T_target_source, kTruth), deg2rad(0.3));

  searching.normal_search_neighbours = 0;
  EXPECT_FALSE(searching.validate().ok());
}

TEST(DegeneracyAwareIcp, ThreePlaneCornerFullSixDof) {
  const WallPair w = makeClouds({wallX(), wallY(), floorZ()}, 0.02);
  Vector6d x0 = toXyzRpy(kTruth);
  x0(kX) += 0.15;
  x0(kY) -= 0.15;
  x0(kZ) += 0.15;
  x0(kRoll) += deg2rad(1.5);
  x0(kPitch) -= deg2rad(1.5);
  x0(kYaw) += deg2rad(3.0);
  PointToPlaneConfig cfg;
  cfg.dofs = IcpDofs::kFull;
  auto r = icpPointToPlane(w.source, w.target, fromXyzRpy(x0), cfg);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->converged);
  EXPECT_EQ(r->V_u.rows(), 6);
  EXPECT_LT(geometry::translationDistance(r->T_target_source, kTruth), 0.02);
  EXPECT_LT(geometry::rotationAngle(r->T_target_source, kTruth), deg2rad(0.5));
}

TEST(PointToPoint2dIcp, RecoversCornerAndAppliesAcceptanceChecks) {
  // Source: the target's own samples seen from the source frame with range noise (as PCL's 2D ICP
  // expects overlapping samplings).
  const PointCloud target = samplePlanes({wallX(), wallY()}, Pose3::Identity(), 0.1, 0.01, 0.0, 21);
  PointCloud source;
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 0.005);
  for (const Eigen::Vector3d& p : target.points) {
    source.points.push_back(kTruth.inverse() * p + Eigen::Vector3d(g(rng), g(rng), g(rng)));
  }
  Vector6d x0 = toXyzRpy(kTruth);
  x0(kX) += 0.18;
  x0(kY) += 0.24;
  x0(kYaw) -= deg2rad(3.0);
  const Pose3 T_odom = fromXyzRpy(x0);
  auto r = icpPointToPoint2d(source, target, T_odom, {});
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_TRUE(r->converged);
  EXPECT_LT(geometry::translationDistance(r->T_target_source, kTruth), 0.02);
  EXPECT_LT(geometry::rotationAngle(r->T_target_source, kTruth), deg2rad(0.5));
  EXPECT_LT(r->fitness_m2, 1e-3);

  IcpAcceptanceConfig acc;  // 1e-3 m^2/s on x and y
  // 0.3 m disagreement: accepted after 100 s (bound sqrt(0.2) = 0.45 m) ...
  const IcpAcceptance ok = checkIcpAcceptance(*r, T_odom, 100.0, acc);
  EXPECT_TRUE(ok.accepted) << ok.reason;
  EXPECT_NEAR(ok.drift_bound_m, std::sqrt(0.2), 1e-12);
  EXPECT_NEAR(ok.translation_disagreement_m, 0.3, 0.02);
  // ... rejected after 10 s (bound 0.14 m): more than the odometry can have drifted.
  const IcpAcceptance drift = checkIcpAcceptance(*r, T_odom, 10.0, acc);
  EXPECT_FALSE(drift.accepted);
  EXPECT_NE(drift.reason.find("drift bound"), std::string::npos) << drift.reason;
  // Criterion 2: a fitness threshold below the achieved fitness rejects.
  acc.max_fitness_m2 = r->fitness_m2 / 2;
  EXPECT_FALSE(checkIcpAcceptance(*r, T_odom, 100.0, acc).accepted);
  // Criterion 1: an unconverged run (one iteration allowed) rejects.
  PointToPoint2dConfig one;
  one.max_iterations = 1;
  auto r1 = icpPointToPoint2d(source, target, T_odom, one);
  ASSERT_TRUE(r1.ok());
  EXPECT_FALSE(r1->converged);
  EXPECT_FALSE(checkIcpAcceptance(*r1, T_odom, 100.0, IcpAcceptanceConfig{}).accepted);
}

TEST(Icp, BadInputIsAnErrorNeverANanPose) {
  const WallPair w = makeClouds({wallX(), wallY()}, 0.0);
  const Pose3 I = Pose3::Identity();
  PointCloud empty;
  PointCloud tiny;
  for (int i = 0; i < 5; ++i) {
    tiny.points.emplace_back(5.0, 0.1 * i, -2.0);
    tiny.normals.emplace_back(-1.0, 0.0, 0.0);
  }
  for (const PointCloud* bad : {&empty, &tiny}) {
    auto a = icpPointToPlane(*bad, w.target, kTruth, {});
    ASSERT_FALSE(a.ok());
    EXPECT_NE(a.error().message.find("source cloud has"), std::string::npos) << a.error().message;
    EXPECT_FALSE(icpPointToPlane(w.source, *bad, kTruth, {}).ok());
    EXPECT_FALSE(icpPointToPoint2d(*bad, w.target, kTruth, {}).ok());
    EXPECT_FALSE(icpPointToPoint2d(w.source, *bad, kTruth, {}).ok());
  }
  PointCloud no_normals = w.target;
  no_normals.normals.clear();
  auto nn = icpPointToPlane(w.source, no_normals, kTruth, {});
  ASSERT_FALSE(nn.ok());
  EXPECT_NE(nn.error().message.find("normals"), std::string::npos);
  PointCloud nan_cloud = w.source;
  nan_cloud.points[17].y() = std::numeric_limits<double>::quiet_NaN();
  auto np = icpPointToPlane(nan_cloud, w.target, kTruth, {});
  ASSERT_FALSE(np.ok());
  EXPECT_NE(np.error().message.find("point 17"), std::string::npos) << np.error().message;
  EXPECT_FALSE(icpPointToPoint2d(nan_cloud, w.target, kTruth, {}).ok());
  // Clouds 50 m apart: no correspondences, an error rather than a guess.
  const Pose3 far = geometry::poseFromXyzRpy(50, 0, 0, 0, 0, 0);
  auto f = icpPointToPlane(w.source, w.target, far, {});
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("correspondences"), std::string::npos);
  EXPECT_FALSE(icpPointToPoint2d(w.source, w.target, far, {}).ok());
  Pose3 nan_pose = I;
  nan_pose.translation().z() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(icpPointToPlane(w.source, w.target, nan_pose, {}).ok());
  PointToPlaneConfig bad_cfg;
  bad_cfg.sigma_point_m = 0.0;
  auto bc = icpPointToPlane(w.source, w.target, kTruth, bad_cfg);
  ASSERT_FALSE(bc.ok());
  EXPECT_NE(bc.error().message.find("sigma_point_m"), std::string::npos);
  PointToPlaneConfig bad_bound;
  bad_bound.min_correspondence_distance_m = 2.0 * bad_bound.max_correspondence_distance_m;
  auto bb = icpPointToPlane(w.source, w.target, kTruth, bad_bound);
  ASSERT_FALSE(bb.ok());
  EXPECT_NE(bb.error().message.find("min_correspondence_distance_m"), std::string::npos);
  // A cloud of points all at one spot: every direction is degenerate; the estimate stays finite.
  PointCloud blob;
  for (int i = 0; i < 50; ++i) {
    blob.points.emplace_back(5.0, 0.0, -2.0);
    blob.normals.emplace_back(-1.0, 0.0, 0.0);
  }
  auto b = icpPointToPlane(blob, blob, I, {});
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_TRUE(geometry::isValidPose(b->T_target_source));
  EXPECT_LE(b->V_u.rows(), 1);
}

}  // namespace
}  // namespace vog::slam
