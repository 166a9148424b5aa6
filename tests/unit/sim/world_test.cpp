#include "vog/geometry/sonar.hpp"
#include "vog/sim/world.hpp"

#include "test_support.hpp"
#include "world_from_text.hpp"

#include <gtest/gtest.h>

#include <numbers>

#include <fstream>
#include <random>

namespace vog::sim {
namespace {

Eigen::Vector3d randomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// Reference: ray against a finite capped cylinder in its local frame (axis z, |z| <= h/2), solved
// independently of the simulator (sampling the quadratic's roots and cap planes).
std::optional<double> refCylinder(const geometry::Pose3& T, double r, double len, const Eigen::Vector3d& o_w,
                                  const Eigen::Vector3d& d_w, bool caps, double z0, double z1) {
  const Eigen::Vector3d o = T.inverse() * o_w;
  const Eigen::Vector3d d = T.linear().transpose() * d_w;
  (void)len;
  std::optional<double> best;
  const double a = d.head<2>().squaredNorm(), b = 2 * o.head<2>().dot(d.head<2>()),
               c = o.head<2>().squaredNorm() - r * r;
  const double disc = b * b - 4 * a * c;
  if (a > 0 && disc >= 0) {
    for (const double t : {(-b - std::sqrt(disc)) / (2 * a), (-b + std::sqrt(disc)) / (2 * a)}) {
      const double z = o.z() + t * d.z();
      if (t > 0 && z >= z0 && z <= z1 && (!best || t < *best)) best = t;
    }
  }
  if (caps && d.z() != 0) {
    for (const double zc : {z0, z1}) {
      const double t = (zc - o.z()) / d.z();
      if (t > 0 && (o + t * d).head<2>().norm() <= r && (!best || t < *best)) best = t;
    }
  }
  return best;
}

TEST(WorldRayCast, CylinderMatchesAnalyticRanges) {
  const auto w =
      worldFrom("  - {type: cylinder, pose: {xyz: [1, 2, -3], rpy_deg: [5, -10, 30]}, radius: 0.3, length: 6}\n");
  const geometry::Pose3 T =
      geometry::poseFromXyzRpy(1, 2, -3, geometry::deg2rad(5), geometry::deg2rad(-10), geometry::deg2rad(30));
  // Perpendicular shot: distance from the axis minus the radius.
  {
    const Eigen::Vector3d axis_point = T * Eigen::Vector3d(0, 0, 0.7);
    const Eigen::Vector3d side = T.linear() * Eigen::Vector3d(1, 0, 0);
    const auto hit = w->castRay(axis_point + 4.0 * side, -side, 20.0);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->range_m, 3.7, 1e-4);
    EXPECT_NEAR(hit->normal_world.dot(side), 1.0, 1e-6);
  }
  std::mt19937_64 rng(7);
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d o = T * Eigen::Vector3d(0, 0, 0) + 5.0 * randomUnit(rng);
    // Aim near the cylinder so that most rays hit the side or a cap.
    const Eigen::Vector3d target =
        T * Eigen::Vector3d(0.5 * randomUnit(rng).x(), 0.5 * randomUnit(rng).y(), 3.2 * randomUnit(rng).z());
    const Eigen::Vector3d d = (target - o).normalized();
    const auto ref = refCylinder(T, 0.3, 6, o, d, true, -3, 3);
    const auto hit = w->castRay(o, d, 20.0);
    ASSERT_EQ(ref.has_value(), hit.has_value()) << i;
    if (!ref) continue;
    ++hits;
    EXPECT_NEAR(hit->range_m, *ref, 1e-4) << i;
  }
  EXPECT_GT(hits, 500);
}

TEST(WorldRayCast, PlaneMatchesAnalyticRanges) {
  const auto w = worldFrom("  - {type: plane, pose: {xyz: [0.5, -1, -4], rpy_deg: [10, 20, 0]}, size: [14, 10]}\n",
                           "{min: [-20, -20, -20], max: [20, 20, 20]}");
  const geometry::Pose3 T = geometry::poseFromXyzRpy(0.5, -1, -4, geometry::deg2rad(10), geometry::deg2rad(20), 0);
  const Eigen::Vector3d n = T.linear().col(2);
  std::mt19937_64 rng(11);
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d o(std::uniform_real_distribution<double>(-4, 4)(rng),
                            std::uniform_real_distribution<double>(-4, 4)(rng), 0.0);
    Eigen::Vector3d d = randomUnit(rng);
    d.z() = -std::abs(d.z()) - 0.2;
    d.normalize();
    const double t = n.dot(T.translation() - o) / n.dot(d);
    const Eigen::Vector3d p_local = T.inverse() * (o + t * d);
    const bool inside = std::abs(p_local.x()) <= 7 && std::abs(p_local.y()) <= 5 && t > 0 && t <= 30;
    const auto hit = w->castRay(o, d, 30.0);
    // Rays grazing the rectangle's edge may go either way; skip a 1 mm band.
    if (std::abs(std::abs(p_local.x()) - 7) < 1e-3 || std::abs(std::abs(p_local.y()) - 5) < 1e-3) continue;
    ASSERT_EQ(inside, hit.has_value()) << i;
    if (!inside) continue;
    ++hits;
    EXPECT_NEAR(hit->range_m, t, 1e-4) << i;
    EXPECT_NEAR(std::abs(hit->normal_world.dot(n)), 1.0, 1e-6);
  }
  EXPECT_GT(hits, 1000);
}

// Reference: slab method on the box in its own frame.
std::optional<double> refBox(const geometry::Pose3& T, const Eigen::Vector3d& size, const Eigen::Vector3d& o_w,
                             const Eigen::Vector3d& d_w) {
  const Eigen::Vector3d o = T.inverse() * o_w;
  const Eigen::Vector3d d = T.linear().transpose() * d_w;
  double t0 = 0, t1 = 1e9;
  for (int i = 0; i < 3; ++i) {
    const double a = (-0.5 * size[i] - o[i]) / d[i], b = (0.5 * size[i] - o[i]) / d[i];
    t0 = std::max(t0, std::min(a, b));
    t1 = std::min(t1, std::max(a, b));
  }
  if (t0 > t1 || t0 <= 0) return std::nullopt;
  return t0;
}

TEST(WorldRayCast, BoxMatchesAnalyticRanges) {
  const auto w = worldFrom("  - {type: box, pose: {xyz: [2, 1, -3.5], rpy_deg: [0, 15, 30]}, size: [1.0, 0.6, 0.5]}\n");
  const geometry::Pose3 T = geometry::poseFromXyzRpy(2, 1, -3.5, 0, geometry::deg2rad(15), geometry::deg2rad(30));
  std::mt19937_64 rng(3);
  int hits = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d o = T.translation() + 3.0 * randomUnit(rng);
    const Eigen::Vector3d target =
        T * Eigen::Vector3d(0.6 * randomUnit(rng).x(), 0.4 * randomUnit(rng).y(), 0.3 * randomUnit(rng).z());
    const Eigen::Vector3d d = (target - o).normalized();
    const auto ref = refBox(T, Eigen::Vector3d(1.0, 0.6, 0.5), o, d);
    const auto hit = w->castRay(o, d, 20.0);
    if (ref && hit) {
      ++hits;
      EXPECT_NEAR(hit->range_m, *ref, 1e-4) << i;
    } else {
      // Disagreement only for rays grazing an edge within float precision.
      if (ref.has_value() != hit.has_value()) {
        const Eigen::Vector3d p = T.inverse() * (o + (ref ? *ref : hit->range_m) * d);
        const Eigen::Vector3d margin = Eigen::Vector3d(0.5, 0.3, 0.25) - p.cwiseAbs();
        EXPECT_LT(std::min({std::abs(margin.x()), std::abs(margin.y()), std::abs(margin.z())}), 1e-4) << i;
      }
    }
  }
  EXPECT_GT(hits, 1000);
}

TEST(WorldRayCast, TankWallIsHitFromInsideAndNothingBeyondMaxRange) {
  const auto w = worldFrom("  - {type: tank, pose: {xyz: [0, 0, -3], rpy_deg: [0, 0, 0]}, radius: 3.5, height: 3}\n");
  std::mt19937_64 rng(5);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d o(std::uniform_real_distribution<double>(-2, 2)(rng),
                            std::uniform_real_distribution<double>(-2, 2)(rng), -1.5);
    const double a = std::uniform_real_distribution<double>(-3.14, 3.14)(rng);
    const Eigen::Vector3d d(std::cos(a), std::sin(a), 0.0);
    // Exit distance of a ray from inside a circle: t = -o.d + sqrt((o.d)^2 - |o|^2 + r^2).
    const double od = o.head<2>().dot(d.head<2>());
    const double t = -od + std::sqrt(od * od - o.head<2>().squaredNorm() + 3.5 * 3.5);
    const auto hit = w->castRay(o, d, 20.0);
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->range_m, t, 1e-4);
    EXPECT_FALSE(w->castRay(o, d, t - 0.01));
  }
  // Open top: straight up from inside sees nothing; no floor: straight down neither.
  EXPECT_FALSE(w->castRay(Eigen::Vector3d(0, 0, -1.5), Eigen::Vector3d::UnitZ(), 20.0));
  EXPECT_FALSE(w->castRay(Eigen::Vector3d(0, 0, -1.5), -Eigen::Vector3d::UnitZ(), 20.0));
}

TEST(WorldRayCast, MeshCubeMatchesTheBoxPrimitive) {
  vog::test::TempDir dir("vog-sim-world");
  // A unit cube as an ASCII OBJ, scaled by 2 in the scene: the same as a 2 m box.
  std::ofstream(dir.path() / "cube.obj") << "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n"
                                            "v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n"
                                            "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n"
                                            "f 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
  const auto mesh =
      worldFrom("  - {type: mesh, pose: {xyz: [1, 0, 0], rpy_deg: [0, 0, 40]}, file: cube.obj, scale: 2.0}\n",
                "{min: [-10, -10, -10], max: [10, 10, 10]}", dir.path());
  const auto box = worldFrom("  - {type: box, pose: {xyz: [1, 0, 0], rpy_deg: [0, 0, 40]}, size: [2, 2, 2]}\n");
  std::mt19937_64 rng(9);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d o = Eigen::Vector3d(1, 0, 0) + 4.0 * randomUnit(rng);
    const Eigen::Vector3d d = (Eigen::Vector3d(1, 0, 0) + 0.8 * randomUnit(rng) - o).normalized();
    const auto a = mesh->castRay(o, d, 20), b = box->castRay(o, d, 20);
    ASSERT_TRUE(a && b);
    EXPECT_NEAR(a->range_m, b->range_m, 1e-5);
  }
}

TEST(WorldCollision, BoxAgainstCylinderAtTheExactClearance) {
  const auto w =
      worldFrom("  - {type: cylinder, pose: {xyz: [0, 0, 0], rpy_deg: [0, 0, 0]}, radius: 0.3, length: 6}\n");
  const Eigen::Vector3d half(0.5, 0.5, 0.25);
  // Face of the box toward the cylinder at distance 0.3 + 0.5 from the axis: touching.
  EXPECT_FALSE(w->boxCollides(geometry::poseFromXyzRpy(0.81, 0, 0, 0, 0, 0), half));
  EXPECT_TRUE(w->boxCollides(geometry::poseFromXyzRpy(0.79, 0, 0, 0, 0, 0), half));
  // Rotated 45 deg the corner leads: clearance is 0.3 + 0.5 * sqrt(2).
  EXPECT_FALSE(w->boxCollides(geometry::poseFromXyzRpy(0.3 + 0.7071 + 0.01, 0, 0, 0, 0, M_PI / 4), half));
  EXPECT_TRUE(w->boxCollides(geometry::poseFromXyzRpy(0.3 + 0.7071 - 0.01, 0, 0, 0, 0, M_PI / 4), half));
  // Above the top cap.
  EXPECT_FALSE(w->boxCollides(geometry::poseFromXyzRpy(0, 0, 3.26, 0, 0, 0), half));
  EXPECT_TRUE(w->boxCollides(geometry::poseFromXyzRpy(0, 0, 3.24, 0, 0, 0), half));
}

TEST(WorldCollision, PlaneAndSolidInterior) {
  const auto w = worldFrom(
      "  - {type: plane, pose: {xyz: [0, 0, -4]}, size: [14, 10]}\n"
      "  - {type: box, pose: {xyz: [5, 0, 0]}, size: [4, 4, 4]}\n");
  const Eigen::Vector3d half(0.5, 0.5, 0.25);
  EXPECT_FALSE(w->boxCollides(geometry::poseFromXyzRpy(0, 0, -3.74, 0, 0, 0), half));
  EXPECT_TRUE(w->boxCollides(geometry::poseFromXyzRpy(0, 0, -3.76, 0, 0, 0), half));
  EXPECT_TRUE(w->boxCollides(geometry::poseFromXyzRpy(0, 0, -4.2, 0, 0, 0), half));  // straddling the seabed
  EXPECT_TRUE(w->boxCollides(geometry::poseFromXyzRpy(5, 0, 0, 0, 0, 0), half));     // deep inside the solid box
  EXPECT_FALSE(w->boxCollides(geometry::poseFromXyzRpy(2.4, 0, 0, 0, 0, 0), half));
  EXPECT_TRUE(w->boxCollides(geometry::poseFromXyzRpy(2.6, 0, 0, 0, 0, 0), half));
}

TEST(WorldSurface, SamplesLieOnTheSurfacesAtTheRequestedDensity) {
  const auto w = worldFrom(
      "  - {type: cylinder, pose: {xyz: [0, 0, 0], rpy_deg: [0, 0, 0]}, radius: 0.5, length: 2}\n"
      "  - {type: plane, pose: {xyz: [0, 0, -4]}, size: [4, 3]}\n");
  const double spacing = 0.05;
  const auto cloud = w->sampleSurface(spacing, 1);
  ASSERT_TRUE(cloud.hasNormals());
  std::size_t on_plane = 0, on_cyl = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& p = cloud.points[i];
    EXPECT_NEAR(cloud.normals[i].norm(), 1.0, 1e-9);
    if (std::abs(p.z() + 4) < 1e-9) {
      ++on_plane;
      EXPECT_LE(std::abs(p.x()), 2.0 + 1e-9);
      EXPECT_LE(std::abs(p.y()), 1.5 + 1e-9);
    } else {
      ++on_cyl;
      const bool side = std::abs(p.head<2>().norm() - 0.5) < 1e-9 && std::abs(p.z()) <= 1.0;
      const bool cap = std::abs(std::abs(p.z()) - 1.0) < 1e-9 && p.head<2>().norm() <= 0.5;
      EXPECT_TRUE(side || cap) << p.transpose();
    }
  }
  const double plane_expected = 12.0 / (spacing * spacing);
  const double cyl_expected = (2 * M_PI * 0.5 * 2 + 2 * M_PI * 0.25) / (spacing * spacing);
  EXPECT_NEAR(static_cast<double>(on_plane), plane_expected, 0.05 * plane_expected);
  EXPECT_NEAR(static_cast<double>(on_cyl), cyl_expected, 0.1 * cyl_expected);
  // Deterministic per seed.
  EXPECT_EQ(w->sampleSurface(spacing, 1).points, cloud.points);
}

TEST(WorldObservable, HiddenAndOutOfBoxPointsAreNotObservable) {
  // A seabed wider than the box and a solid block resting on it: the seabed under the block is
  // hidden, the seabed outside the box is out, the block's top is seen.
  const auto w = worldFrom(
      "  - {type: plane, pose: {xyz: [0, 0, -4]}, size: [16, 16]}\n"
      "  - {type: box, pose: {xyz: [0, 0, -3.5]}, size: [2, 2, 1]}\n",
      "{min: [-5, -5, -4], max: [5, 5, 0]}");
  geometry::PointCloud pts;
  pts.points = {{0, 0, -4}, {-3, 3, -4}, {7, 0, -4}, {0.5, 0.5, -3}};
  ObservableConfig cfg;
  auto obs = observablePoints(*w, pts, cfg);
  ASSERT_TRUE(obs.ok()) << obs.error().message;
  EXPECT_GT(obs->n_viewpoints, 100u);
  const auto& seen = obs->points.points;
  auto has = [&](const Eigen::Vector3d& p) { return std::find(seen.begin(), seen.end(), p) != seen.end(); };
  EXPECT_FALSE(has({0, 0, -4}));     // under the block
  EXPECT_TRUE(has({-3, 3, -4}));     // open seabed
  EXPECT_FALSE(has({7, 0, -4}));     // outside the box
  EXPECT_TRUE(has({0.5, 0.5, -3}));  // top of the block
  EXPECT_EQ(seen.size(), 2u);
}

TEST(WorldObservable, MaxRangeLimitsVisibility) {
  const auto w =
      worldFrom("  - {type: plane, pose: {xyz: [0, 0, -10]}, size: [4, 4]}\n", "{min: [-2, -2, -10], max: [2, 2, 0]}");
  geometry::PointCloud pts;
  pts.points = {{0, 0, -10}};
  ObservableConfig cfg;
  cfg.min_elevation_rad = -std::numbers::pi / 2;  // straight down, from any range: this test is about the maximum
  cfg.min_range_m = 0.0;
  cfg.max_range_m = 0.5;  // nearest viewpoint centre is 0.25 + margin above: collision box forbids it
  auto near = observablePoints(*w, pts, cfg);
  ASSERT_TRUE(near.ok());
  EXPECT_TRUE(near->points.empty());
  cfg.max_range_m = 2.0;
  auto far = observablePoints(*w, pts, cfg);
  ASSERT_TRUE(far.ok());
  EXPECT_EQ(far->points.size(), 1u);
  cfg.viewpoint_spacing_m = 0.0;
  EXPECT_FALSE(observablePoints(*w, pts, cfg).ok());
}

TEST(WorldObservable, OnlyPositionsReachableFromTheStartCount) {
  // A seabed across the whole box at z = -2 and a crate under it: the free positions under the
  // seabed would see the crate, but the vehicle starts above the seabed and cannot get there.
  const std::string objects =
      "  - {type: plane, pose: {xyz: [0, 0, -2]}, size: [30, 30]}\n"
      "  - {type: box, pose: {xyz: [0, 0, -4]}, size: [0.4, 0.4, 0.4]}\n";
  geometry::PointCloud pts;
  pts.points = {{0, 0, -3.8}, {1, 1, -2}};
  auto from = [&](const std::string& start) {
    const std::string text =
        "name: t\nbounds: {min: [-3, -3, -5], max: [3, 3, 0]}\nstart: {xyz: " + start + "}\nobjects:\n" + objects;
    auto scene = parseScene(text, "t.yaml", ".");
    EXPECT_TRUE(scene.ok()) << scene.error().message;
    auto world = World::create(*scene);
    EXPECT_TRUE(world.ok());
    auto obs = observablePoints(**world, pts, {});
    EXPECT_TRUE(obs.ok()) << obs.error().message;
    return std::move(obs).value();
  };
  const ObservableResult above = from("[0, 0, -0.5]");
  ASSERT_EQ(above.points.size(), 1u);
  EXPECT_EQ(above.points.points[0], Eigen::Vector3d(1, 1, -2));  // the seabed, from above
  const ObservableResult below = from("[2, 2, -4.5]");
  EXPECT_EQ(below.points.size(), 2u);  // a vehicle started under the sheet sees the crate (and the sheet)
  // Neither side reaches across the sheet: together fewer than the 12 x 12 x 10 positions of the box.
  EXPECT_GT(above.n_viewpoints, 0u);
  EXPECT_GT(below.n_viewpoints, 0u);
  EXPECT_LT(above.n_viewpoints + below.n_viewpoints, 12u * 12u * 10u);
}

TEST(WorldObservable, TheFanSeesOnlyTheElevationsOfItsBeams) {
  // The defaults are the thesis's vertical fan: 29 deg wide, so +-14.5 deg about the horizontal.
  const ObservableConfig defaults;
  const ObservableConfig thesis = ObservableConfig::ofFan(geometry::SonarFan{});
  EXPECT_NEAR(thesis.min_elevation_rad, defaults.min_elevation_rad, 1e-12);
  EXPECT_NEAR(thesis.max_elevation_rad, defaults.max_elevation_rad, 1e-12);
  EXPECT_NEAR(defaults.max_elevation_rad, geometry::deg2rad(14.5), 1e-12);
  EXPECT_EQ(thesis.max_range_m, defaults.max_range_m);
  EXPECT_EQ(thesis.min_range_m, defaults.min_range_m);
  // A shaft 1 m wide down to the seabed: every position in it is right above the seabed point, so
  // the level vertical fan never points at it; a fan pitched 60 deg down does, and so would a
  // line of sight in any direction.
  const auto w = worldFrom("  - {type: plane, pose: {xyz: [0, 0, -4]}, size: [16, 16]}\n",
                           "{min: [-0.5, -0.5, -4], max: [0.5, 0.5, 0]}");
  geometry::PointCloud pts;
  pts.points = {{0, 0, -4}};
  auto level = observablePoints(*w, pts, thesis);
  ASSERT_TRUE(level.ok()) << level.error().message;
  EXPECT_GT(level->n_viewpoints, 0u);
  EXPECT_TRUE(level->points.empty());
  geometry::SonarFan pitched;
  pitched.T_vehicle_sensor =
      geometry::poseFromXyzRpy(0, 0, 0, 0, geometry::deg2rad(60.0), 0) * pitched.T_vehicle_sensor;
  const ObservableConfig down = ObservableConfig::ofFan(pitched);
  EXPECT_NEAR(down.min_elevation_rad, geometry::deg2rad(-74.5), 1e-9);
  EXPECT_NEAR(down.max_elevation_rad, geometry::deg2rad(-45.5), 1e-9);
  auto seen = observablePoints(*w, pts, down);
  ASSERT_TRUE(seen.ok()) << seen.error().message;
  EXPECT_EQ(seen->points.size(), 1u);
  ObservableConfig any = thesis;
  any.min_elevation_rad = -std::numbers::pi / 2;
  any.max_elevation_rad = std::numbers::pi / 2;
  EXPECT_EQ(observablePoints(*w, pts, any)->points.size(), 1u);
  // Bad elevations and ranges are refused, naming the field.
  ObservableConfig bad = thesis;
  bad.min_elevation_rad = 0.5;
  bad.max_elevation_rad = 0.2;
  ASSERT_FALSE(bad.validate().ok());
  EXPECT_NE(bad.validate().error().message.find("elevation"), std::string::npos);
  bad = thesis;
  bad.min_range_m = 20.0;
  ASSERT_FALSE(bad.validate().ok());
  EXPECT_NE(bad.validate().error().message.find("min_range_m"), std::string::npos);
}

}  // namespace
}  // namespace vog::sim
