#include "world_impl.hpp"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace vog::sim {

Status WorldConfig::validate() const {
  if (collision_sides < 8 || collision_sides > 4096)
    return Error{"world.collision_sides must be in [8, 4096], got " + std::to_string(collision_sides)};
  if (!(collision_cell_m > 0.01) || !std::isfinite(collision_cell_m))
    return Error{"world.collision_cell_m must be finite and > 0.01, got " + std::to_string(collision_cell_m)};
  return {};
}

World::Impl::~Impl() {
  if (rtc_scene != nullptr) rtcReleaseScene(rtc_scene);
  if (device != nullptr) rtcReleaseDevice(device);
}

World::~World() = default;

Eigen::AlignedBox3d AnalyticCylinder::worldBounds() const {
  Eigen::AlignedBox3d box;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d corner((i & 1) ? radius_m : -radius_m, (i & 2) ? radius_m : -radius_m, (i & 4) ? z1_m : z0_m);
    box.extend(T_world_local * corner);
  }
  return box;
}

std::optional<std::pair<double, Eigen::Vector3d>> AnalyticCylinder::intersect(const Eigen::Vector3d& origin_world,
                                                                              const Eigen::Vector3d& dir_world,
                                                                              double t_near, double t_far) const {
  const Eigen::Vector3d o = T_local_world * origin_world;
  const Eigen::Vector3d d = T_local_world.linear() * dir_world;
  double best_t = t_far;
  Eigen::Vector3d best_n = Eigen::Vector3d::Zero();
  bool found = false;

  // Side: (ox + t dx)^2 + (oy + t dy)^2 = r^2.
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > 1e-20) {
    const double b = o.x() * d.x() + o.y() * d.y();  // half of the linear coefficient
    const double c = o.x() * o.x() + o.y() * o.y() - radius_m * radius_m;
    const double disc = b * b - a * c;
    if (disc >= 0.0) {
      const double sq = std::sqrt(disc);
      // Numerically stable pair of roots (Numerical Recipes 5.6).
      const double q = -(b + std::copysign(sq, b));
      double t1 = q / a;
      double t2 = q != 0.0 ? c / q : t1;
      if (t1 > t2) std::swap(t1, t2);
      for (const double t : {t1, t2}) {
        if (t > t_near && t < best_t) {
          const double z = o.z() + t * d.z();
          if (z >= z0_m && z <= z1_m) {
            best_t = t;
            best_n = Eigen::Vector3d(o.x() + t * d.x(), o.y() + t * d.y(), 0.0) / radius_m;
            found = true;
            break;
          }
        }
      }
    }
  }
  if (caps && std::abs(d.z()) > 1e-20) {
    for (const double zc : {z0_m, z1_m}) {
      const double t = (zc - o.z()) / d.z();
      if (t > t_near && t < best_t) {
        const double x = o.x() + t * d.x();
        const double y = o.y() + t * d.y();
        if (x * x + y * y <= radius_m * radius_m) {
          best_t = t;
          best_n = Eigen::Vector3d(0.0, 0.0, zc == z1_m ? 1.0 : -1.0);
          found = true;
        }
      }
    }
  }
  if (!found) return std::nullopt;
  return std::make_pair(best_t, Eigen::Vector3d(T_world_local.linear() * best_n));
}

namespace {

// Embree user-geometry callbacks for the analytic cylinders (Embree 3 API: rtcSetGeometry*Function).
void cylinderBounds(const RTCBoundsFunctionArguments* args) {
  const auto* cyls = static_cast<const std::vector<AnalyticCylinder>*>(args->geometryUserPtr);
  const Eigen::AlignedBox3d b = (*cyls)[args->primID].worldBounds();
  args->bounds_o->lower_x = static_cast<float>(b.min().x());
  args->bounds_o->lower_y = static_cast<float>(b.min().y());
  args->bounds_o->lower_z = static_cast<float>(b.min().z());
  args->bounds_o->upper_x = static_cast<float>(b.max().x());
  args->bounds_o->upper_y = static_cast<float>(b.max().y());
  args->bounds_o->upper_z = static_cast<float>(b.max().z());
}

void cylinderIntersect(const RTCIntersectFunctionNArguments* args) {
  const auto* cyls = static_cast<const std::vector<AnalyticCylinder>*>(args->geometryUserPtr);
  const AnalyticCylinder& cyl = (*cyls)[args->primID];
  RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, args->N);
  RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, args->N);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const Eigen::Vector3d o(RTCRayN_org_x(ray, args->N, i), RTCRayN_org_y(ray, args->N, i),
                            RTCRayN_org_z(ray, args->N, i));
    const Eigen::Vector3d d(RTCRayN_dir_x(ray, args->N, i), RTCRayN_dir_y(ray, args->N, i),
                            RTCRayN_dir_z(ray, args->N, i));
    const auto h = cyl.intersect(o, d, RTCRayN_tnear(ray, args->N, i), RTCRayN_tfar(ray, args->N, i));
    if (!h) continue;
    RTCRayN_tfar(ray, args->N, i) = static_cast<float>(h->first);
    RTCHitN_Ng_x(hit, args->N, i) = static_cast<float>(h->second.x());
    RTCHitN_Ng_y(hit, args->N, i) = static_cast<float>(h->second.y());
    RTCHitN_Ng_z(hit, args->N, i) = static_cast<float>(h->second.z());
    RTCHitN_u(hit, args->N, i) = 0.0f;
    RTCHitN_v(hit, args->N, i) = 0.0f;
    RTCHitN_primID(hit, args->N, i) = args->primID;
    RTCHitN_geomID(hit, args->N, i) = args->geomID;
    RTCHitN_instID(hit, args->N, i, 0) = args->context->instID[0];
  }
}

void cylinderOccluded(const RTCOccludedFunctionNArguments* args) {
  const auto* cyls = static_cast<const std::vector<AnalyticCylinder>*>(args->geometryUserPtr);
  const AnalyticCylinder& cyl = (*cyls)[args->primID];
  RTCRayN* ray = args->ray;
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const Eigen::Vector3d o(RTCRayN_org_x(ray, args->N, i), RTCRayN_org_y(ray, args->N, i),
                            RTCRayN_org_z(ray, args->N, i));
    const Eigen::Vector3d d(RTCRayN_dir_x(ray, args->N, i), RTCRayN_dir_y(ray, args->N, i),
                            RTCRayN_dir_z(ray, args->N, i));
    if (cyl.intersect(o, d, RTCRayN_tnear(ray, args->N, i), RTCRayN_tfar(ray, args->N, i)))
      RTCRayN_tfar(ray, args->N, i) = -std::numeric_limits<float>::infinity();
  }
}

void addBoxTriangles(const geometry::Pose3& T, const Eigen::Vector3d& size, std::vector<Triangle>& out) {
  const Eigen::Vector3d h = 0.5 * size;
  auto v = [&](int i) {
    return Eigen::Vector3d(
        T * Eigen::Vector3d((i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(), (i & 4) ? h.z() : -h.z()));
  };
  // Each face as two triangles over its corner indices (bit 0: +x, bit 1: +y, bit 2: +z).
  static constexpr int kFaces[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1},
                                       {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
  for (const auto& f : kFaces) {
    out.push_back({v(f[0]), v(f[1]), v(f[2])});
    out.push_back({v(f[0]), v(f[2]), v(f[3])});
  }
}

void addPlaneTriangles(const geometry::Pose3& T, const Eigen::Vector3d& size, std::vector<Triangle>& out) {
  const double hx = 0.5 * size.x();
  const double hy = 0.5 * size.y();
  const Eigen::Vector3d p0 = T * Eigen::Vector3d(-hx, -hy, 0), p1 = T * Eigen::Vector3d(hx, -hy, 0);
  const Eigen::Vector3d p2 = T * Eigen::Vector3d(hx, hy, 0), p3 = T * Eigen::Vector3d(-hx, hy, 0);
  out.push_back({p0, p1, p2});
  out.push_back({p0, p2, p3});
}

// Circumscribed prism of a cylinder (conservative for collision): the polygon's edges touch the
// circle at their midpoints, so the prism contains the cylinder.
void addPrismTriangles(const AnalyticCylinder& c, int sides, std::vector<Triangle>& out) {
  const double r = c.radius_m / std::cos(std::numbers::pi / sides);
  auto at = [&](int k, double z) {
    const double a = 2.0 * std::numbers::pi * k / sides;
    return Eigen::Vector3d(c.T_world_local * Eigen::Vector3d(r * std::cos(a), r * std::sin(a), z));
  };
  const Eigen::Vector3d bottom = c.T_world_local * Eigen::Vector3d(0, 0, c.z0_m);
  const Eigen::Vector3d top = c.T_world_local * Eigen::Vector3d(0, 0, c.z1_m);
  for (int k = 0; k < sides; ++k) {
    const Eigen::Vector3d a0 = at(k, c.z0_m), a1 = at(k + 1, c.z0_m), b0 = at(k, c.z1_m), b1 = at(k + 1, c.z1_m);
    out.push_back({a0, a1, b1});
    out.push_back({a0, b1, b0});
    if (c.caps) {
      out.push_back({bottom, a1, a0});
      out.push_back({top, b0, b1});
    }
  }
}

Result<std::vector<Triangle>> loadMesh(const SceneObject& o) {
  Assimp::Importer importer;
  const aiScene* s = importer.ReadFile(o.mesh_file.string(), aiProcess_Triangulate | aiProcess_PreTransformVertices);
  if (s == nullptr)
    return Error{o.where + ": " + o.name + ".file: cannot load mesh " + o.mesh_file.string() + ": " +
                 importer.GetErrorString()};
  std::vector<Triangle> tris;
  for (unsigned m = 0; m < s->mNumMeshes; ++m) {
    const aiMesh* mesh = s->mMeshes[m];
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines have no surface
      Eigen::Vector3d v[3];
      for (int k = 0; k < 3; ++k) {
        const aiVector3D& p = mesh->mVertices[face.mIndices[k]];
        v[k] = o.T_world_object * (o.scale * Eigen::Vector3d(p.x, p.y, p.z));
        if (!v[k].allFinite())
          return Error{o.where + ": " + o.name + ".file: mesh " + o.mesh_file.string() + " has a non-finite vertex"};
      }
      if ((v[1] - v[0]).cross(v[2] - v[0]).norm() < 1e-12) continue;  // degenerate: no area, never hit
      tris.push_back({v[0], v[1], v[2]});
    }
  }
  if (tris.empty())
    return Error{o.where + ": " + o.name + ".file: mesh " + o.mesh_file.string() + " has no triangles with area"};
  return tris;
}

}  // namespace

Result<std::unique_ptr<World>> World::create(const Scene& scene, const WorldConfig& config) {
  if (auto st = config.validate(); !st) return st.error();
  std::unique_ptr<World> w(new World());
  w->scene_ = scene;
  w->impl_ = std::make_unique<Impl>();
  Impl& im = *w->impl_;
  im.config = config;

  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& o = scene.objects[i];
    if (!geometry::isValidPose(o.T_world_object))
      return Error{o.where + ": " + o.name + ".pose: not a valid rigid transform"};
    switch (o.type) {
      case ObjectType::kBox: addBoxTriangles(o.T_world_object, o.size_m, w->triangles_); break;
      case ObjectType::kPlane: addPlaneTriangles(o.T_world_object, o.size_m, w->triangles_); break;
      case ObjectType::kMesh: {
        auto tris = loadMesh(o);
        if (!tris) return tris.error();
        w->triangles_.insert(w->triangles_.end(), tris->begin(), tris->end());
        break;
      }
      case ObjectType::kCylinder:
      case ObjectType::kTank: {
        if (!(o.radius_m > 0.0) || !((o.type == ObjectType::kCylinder ? o.length_m : o.height_m) > 0.0))
          return Error{o.where + ": " + o.name + ": radius and " +
                       (o.type == ObjectType::kCylinder ? "length" : "height") + " must be > 0"};
        AnalyticCylinder c;
        c.T_world_local = o.T_world_object;
        c.T_local_world = o.T_world_object.inverse();
        c.radius_m = o.radius_m;
        c.caps = o.type == ObjectType::kCylinder;
        c.z0_m = c.caps ? -0.5 * o.length_m : 0.0;
        c.z1_m = c.caps ? 0.5 * o.length_m : o.height_m;
        c.object_index = static_cast<int>(i);
        im.cylinders.push_back(c);
        break;
      }
    }
    w->triangle_object_.resize(w->triangles_.size(), static_cast<int>(i));
  }

  im.device = rtcNewDevice("threads=1");
  if (im.device == nullptr) return Error{"embree: cannot create a device"};
  im.rtc_scene = rtcNewScene(im.device);
  rtcSetSceneBuildQuality(im.rtc_scene, RTC_BUILD_QUALITY_HIGH);
  // Robust mode keeps triangle tests watertight: a ray through an edge shared by two faces (common
  // in axis-aligned scenes) hits one of them instead of slipping between.
  rtcSetSceneFlags(im.rtc_scene, RTC_SCENE_FLAG_ROBUST);

  if (!w->triangles_.empty()) {
    RTCGeometry g = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    const std::size_t n = w->triangles_.size();
    auto* vb = static_cast<float*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
    auto* ib = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n));
    if (vb == nullptr || ib == nullptr) {
      rtcReleaseGeometry(g);
      return Error{"embree: cannot allocate the triangle buffers"};
    }
    for (std::size_t t = 0; t < n; ++t) {
      const Triangle& tri = w->triangles_[t];
      const Eigen::Vector3d* v[3] = {&tri.a, &tri.b, &tri.c};
      for (std::size_t k = 0; k < 3; ++k) {
        for (int j = 0; j < 3; ++j) vb[9 * t + 3 * k + static_cast<std::size_t>(j)] = static_cast<float>((*v[k])[j]);
        ib[3 * t + k] = static_cast<unsigned>(3 * t + k);
      }
    }
    rtcCommitGeometry(g);
    im.triangle_geom_id = rtcAttachGeometry(im.rtc_scene, g);
    rtcReleaseGeometry(g);
  }
  if (!im.cylinders.empty()) {
    RTCGeometry g = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, static_cast<unsigned>(im.cylinders.size()));
    rtcSetGeometryUserData(g, &im.cylinders);
    rtcSetGeometryBoundsFunction(g, cylinderBounds, nullptr);
    rtcSetGeometryIntersectFunction(g, cylinderIntersect);
    rtcSetGeometryOccludedFunction(g, cylinderOccluded);
    rtcCommitGeometry(g);
    im.cylinder_geom_id = rtcAttachGeometry(im.rtc_scene, g);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(im.rtc_scene);
  if (const RTCError e = rtcGetDeviceError(im.device); e != RTC_ERROR_NONE)
    return Error{"embree: scene build failed with error code " + std::to_string(static_cast<int>(e))};

  std::vector<Triangle> collision = w->triangles_;
  for (const auto& c : im.cylinders) addPrismTriangles(c, config.collision_sides, collision);
  im.collision.build(std::move(collision), config.collision_cell_m);
  return w;
}

std::optional<RayHit> World::castRay(const Eigen::Vector3d& origin_world, const Eigen::Vector3d& dir_world,
                                     double max_range_m) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh{};
  rh.ray.org_x = static_cast<float>(origin_world.x());
  rh.ray.org_y = static_cast<float>(origin_world.y());
  rh.ray.org_z = static_cast<float>(origin_world.z());
  rh.ray.dir_x = static_cast<float>(dir_world.x());
  rh.ray.dir_y = static_cast<float>(dir_world.y());
  rh.ray.dir_z = static_cast<float>(dir_world.z());
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = static_cast<float>(max_range_m);
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.flags = 0;
  rh.ray.time = 0.0f;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->rtc_scene, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;

  RayHit hit;
  hit.range_m = rh.ray.tfar;
  Eigen::Vector3d n(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
  const double len = n.norm();
  n = len > 0.0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d(-dir_world);
  if (n.dot(dir_world) > 0.0) n = -n;
  hit.normal_world = n;
  if (rh.hit.geomID == impl_->triangle_geom_id) {
    hit.object_index = triangle_object_[rh.hit.primID];
  } else {
    const AnalyticCylinder& c = impl_->cylinders[rh.hit.primID];
    hit.object_index = c.object_index;
    // Embree carries the distance as a float; recompute it in double on the exact surface so
    // analytic shapes keep their full accuracy.
    if (const auto h = c.intersect(origin_world, dir_world, 0.0, static_cast<double>(rh.ray.tfar) + 1e-3)) {
      hit.range_m = h->first;
    }
  }
  return hit;
}

bool World::segmentBlocked(const Eigen::Vector3d& from_world, const Eigen::Vector3d& to_world,
                           double end_margin_m) const {
  const Eigen::Vector3d d = to_world - from_world;
  const double len = d.norm();
  if (len <= end_margin_m) return false;
  const Eigen::Vector3d u = d / len;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay ray{};
  ray.org_x = static_cast<float>(from_world.x());
  ray.org_y = static_cast<float>(from_world.y());
  ray.org_z = static_cast<float>(from_world.z());
  ray.dir_x = static_cast<float>(u.x());
  ray.dir_y = static_cast<float>(u.y());
  ray.dir_z = static_cast<float>(u.z());
  ray.tnear = 0.0f;
  ray.tfar = static_cast<float>(len - end_margin_m);
  ray.mask = 0xFFFFFFFFu;
  ray.flags = 0;
  ray.time = 0.0f;
  rtcOccluded1(impl_->rtc_scene, &ctx, &ray);
  return ray.tfar < 0.0f;
}

}  // namespace vog::sim
