#pragma once
// The simulated world: a Scene turned into Embree geometry for ray casting, plus collision
// geometry for the vehicle's box and a dense ground-truth surface sampler.
//
// Lifecycle: World::create() loads meshes, builds and commits the Embree scene and the collision
// index; afterwards a World is immutable and every const method may be called from any thread.
// Copy is deleted (it owns the Embree device). Models that borrow a World (vehicle, sonar) must not
// outlive it.

#include "vog/geometry/point_cloud.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/geometry/sonar.hpp"
#include "vog/core/result.hpp"
#include "vog/sim/scene.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace vog::sim {

struct Triangle {
  Eigen::Vector3d a, b, c;  // world frame
};

struct RayHit {
  double range_m = 0.0;          // distance from the origin along the unit direction
  Eigen::Vector3d normal_world;  // unit geometric normal, facing the ray origin
  int object_index = -1;         // index into Scene::objects
};

struct WorldConfig {
  // Cylinders and tank walls are exact (analytic) for ray casting; the collision geometry replaces
  // them by circumscribed prisms with this many sides, so the collision test is conservative by at
  // most radius * (1 / cos(pi / n) - 1) (1 mm for a 3.5 m tank at 128 sides).
  int collision_sides = 128;
  // Cell size of the uniform grid that indexes collision triangles.
  double collision_cell_m = 0.5;

  Status validate() const;
};

class World {
 public:
  // Errors: bad config, mesh that assimp cannot read, meshes without triangles, non-finite
  // vertices. Messages name the scene file line of the object.
  static Result<std::unique_ptr<World>> create(const Scene& scene, const WorldConfig& config = {});
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  const Scene& scene() const { return scene_; }

  // Nearest surface hit along the ray from `origin_world` in unit direction `dir_world`, at a
  // distance in (0, max_range_m]; nullopt when nothing is hit.
  std::optional<RayHit> castRay(const Eigen::Vector3d& origin_world, const Eigen::Vector3d& dir_world,
                                double max_range_m) const;

  // True when the open segment from `from_world` to `to_world` hits a surface (shortened by
  // `end_margin_m` at the far end so a point on a surface does not occlude itself).
  bool segmentBlocked(const Eigen::Vector3d& from_world, const Eigen::Vector3d& to_world,
                      double end_margin_m = 1e-3) const;

  // True when the box centred on T_world_box with the given half extents touches any surface, or
  // when its centre is inside a solid box or cylinder object.
  bool boxCollides(const geometry::Pose3& T_world_box, const Eigen::Vector3d& half_extents_m) const;

  // Dense ground-truth surface points with unit normals, about one point per spacing_m^2 of area
  // (cylinders and tanks on a regular grid, triangles by seeded area sampling). Deterministic.
  geometry::PointCloud sampleSurface(double spacing_m, std::uint64_t seed) const;

  // The triangles of planes, boxes and meshes (world frame); cylinders and tanks are analytic.
  const std::vector<Triangle>& triangles() const { return triangles_; }

  // Opaque implementation types (Embree handles, collision index, analytic shapes).
  struct Impl;

 private:
  World() = default;

  Scene scene_;
  std::vector<Triangle> triangles_;
  std::vector<int> triangle_object_;  // object index of each triangle
  std::unique_ptr<Impl> impl_;
};

// Observable ground truth: the surface points inside the exploration box that the sonar can see
// from at least one collision-free vehicle position inside the box that the vehicle can reach from
// its start (not, say, under a seabed that spans the box): an unobstructed line of sight
// between min_range_m and max_range_m whose elevation (angle above the horizontal) lies in
// [min_elevation_rad, max_elevation_rad]. The vehicle stays level and may turn to any heading, so a
// fan mounted on it can point at exactly the directions whose elevation one of its beams has: for
// the vertical fan +-fov/2 about the horizontal, so the seabed right below the vehicle is never in
// view (it is seen farther off, at a grazing angle). Candidate positions are a regular grid over
// the box.
struct ObservableConfig {
  double max_range_m = 11.0;  // thesis Table 4.2, sensor d_max
  double min_range_m = 0.5;   // the fan's window start (geometry::SonarFan)
  // The thesis's vertical fan (29 deg, level): ofFan(geometry::SonarFan{}) gives these.
  double min_elevation_rad = -0.2530727415391778;  // -14.5 deg
  double max_elevation_rad = 0.2530727415391778;
  Eigen::Vector3d collision_box_m{1.0, 1.0, 0.5};  // thesis Table 4.2
  double viewpoint_spacing_m = 0.5;

  // The ranges of `fan` and the elevations its arc spans (beam edges), mounted on a level vehicle
  // (other fields: defaults).
  static ObservableConfig ofFan(const geometry::SonarFan& fan);
  Status validate() const;
};

struct ObservableResult {
  geometry::PointCloud points;
  std::size_t n_viewpoints = 0;  // collision-free grid positions reachable from the start, used
};

Result<ObservableResult> observablePoints(const World& world, const geometry::PointCloud& surface,
                                          const ObservableConfig& config);

}  // namespace vog::sim
