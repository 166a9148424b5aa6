#pragma once
// Scene description: the exploration box, the vehicle start pose and the objects of a simulated
// world, read from a YAML scene file (schema in sim/README.md).
// A Scene is plain data: parsing validates every key and value, so a Scene that exists is usable.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"

#include <Eigen/Geometry>

#include <filesystem>
#include <string>
#include <vector>

namespace vog::sim {

enum class ObjectType { kCylinder, kBox, kPlane, kTank, kMesh };

const char* toString(ObjectType type);

// One object of a scene. Only the fields of its type are meaningful.
//   cylinder: axis = local z, centred on the pose, closed by two end caps (a piling).
//   box:      centred on the pose, size = full extents along local x, y, z.
//   plane:    a rectangle in the local x-y plane (normal = local z), size = (x, y) extents.
//   tank:     a cylindrical wall (no bottom, open top) of `radius_m`, from local z = 0 up to
//             z = height_m: the pose is the centre of the tank's bottom circle.
//   mesh:     triangles loaded with assimp from `mesh_file` (absolute, resolved against the scene
//             file's folder), scaled by `scale` in the object frame, then posed.
struct SceneObject {
  ObjectType type = ObjectType::kBox;
  std::string name;  // optional label; defaults to "objects[i]"
  geometry::Pose3 T_world_object = geometry::Pose3::Identity();
  double radius_m = 0.0;                             // cylinder, tank
  double length_m = 0.0;                             // cylinder
  double height_m = 0.0;                             // tank
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();  // box (x, y, z), plane (x, y, unused)
  std::filesystem::path mesh_file;                   // mesh
  double scale = 1.0;                                // mesh
  std::string where;                                 // "scene.yaml:12" of its entry, for later error messages
};

struct Scene {
  std::string name;
  Eigen::AlignedBox3d bounds_world;                             // exploration box, metres, world frame (z up)
  geometry::Pose3 T_world_start = geometry::Pose3::Identity();  // x, y, z and yaw only
  std::vector<SceneObject> objects;
  std::filesystem::path source_file;  // empty when parsed from text
};

// Reads and validates a scene file. Errors name the file, the line and the key, e.g.
// "pilings.yaml:7: objects[2].radius: must be > 0, got -0.3".
Result<Scene> loadScene(const std::filesystem::path& file);

// Same from text; `source_name` labels errors and `base_dir` resolves mesh paths.
Result<Scene> parseScene(const std::string& yaml_text, const std::string& source_name,
                         const std::filesystem::path& base_dir);

}  // namespace vog::sim
