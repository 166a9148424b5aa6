#pragma once
// Internal parts of World shared by world.cpp, collision.cpp and surface.cpp.

#include "vog/sim/world.hpp"

#include <embree3/rtcore.h>

#include <Eigen/Geometry>

#include <cstdint>
#include <optional>
#include <unordered_map>
#include <vector>

namespace vog::sim {

// A finite circular cylinder about the local z axis, z in [z0, z1]; with end caps (a piling) or
// without (a tank wall, hit from both sides). Intersected analytically in double precision.
struct AnalyticCylinder {
  geometry::Pose3 T_world_local = geometry::Pose3::Identity();
  geometry::Pose3 T_local_world = geometry::Pose3::Identity();
  double radius_m = 0.0;
  double z0_m = 0.0;
  double z1_m = 0.0;
  bool caps = true;
  int object_index = -1;

  Eigen::AlignedBox3d worldBounds() const;
  // Smallest t in (t_near, t_far) where origin + t * dir (world) meets the surface; the normal is
  // in the world frame, not yet oriented toward the ray origin.
  std::optional<std::pair<double, Eigen::Vector3d>> intersect(const Eigen::Vector3d& origin_world,
                                                              const Eigen::Vector3d& dir_world, double t_near,
                                                              double t_far) const;
};

// Uniform grid over collision triangles: each cell lists the triangles whose bounding box touches
// it; triangles spanning too many cells go to `large` and are always tested.
struct CollisionIndex {
  double cell_m = 0.5;
  std::vector<Triangle> triangles;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> cells;
  std::vector<std::uint32_t> large;

  void build(std::vector<Triangle> tris, double cell_size_m);
  std::uint64_t key(int ix, int iy, int iz) const;
  // Candidate triangle indices near a world-frame box, without duplicates.
  std::vector<std::uint32_t> candidates(const Eigen::AlignedBox3d& box_world) const;
};

// Exact overlap test between an oriented box (centre, axes as columns of R, half extents) and a
// triangle, by the separating axis theorem (Akenine-Moeller 2001, 13 axes). Touching counts.
bool boxTriangleOverlap(const geometry::Pose3& T_world_box, const Eigen::Vector3d& half_extents,
                        const Triangle& tri_world);

struct World::Impl {
  RTCDevice device = nullptr;
  RTCScene rtc_scene = nullptr;
  unsigned triangle_geom_id = RTC_INVALID_GEOMETRY_ID;
  unsigned cylinder_geom_id = RTC_INVALID_GEOMETRY_ID;
  std::vector<AnalyticCylinder> cylinders;
  CollisionIndex collision;
  WorldConfig config;

  ~Impl();
};

}  // namespace vog::sim
