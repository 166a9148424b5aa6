#include "vog/sim/scene.hpp"

#include "vog/geometry/sonar.hpp"
#include "vog/yaml/config_reader.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>
#include <sstream>

namespace vog::sim {

const char* toString(ObjectType type) {
  switch (type) {
    case ObjectType::kCylinder: return "cylinder";
    case ObjectType::kBox: return "box";
    case ObjectType::kPlane: return "plane";
    case ObjectType::kTank: return "tank";
    case ObjectType::kMesh: return "mesh";
  }
  return "unknown";
}

namespace {

// Thrown only inside this file and converted to an Error by parseScene: it keeps the many nested
// checks readable. Nothing escapes the public functions.
struct ParseFailure {
  std::string message;
};

std::string formatNumber(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

class Parser {
 public:
  Parser(std::string source, std::filesystem::path base_dir)
      : source_(std::move(source)), base_dir_(std::move(base_dir)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& key, const std::string& what) const {
    throw ParseFailure{yaml::errorAt(source_, node, key, what).message};
  }

  // Rejects keys outside `allowed`, requires those in `required`.
  void checkKeys(const YAML::Node& map, const std::string& key, const std::set<std::string>& allowed,
                 const std::set<std::string>& required) const {
    if (!map.IsMap()) fail(map, key, "must be a mapping");
    for (const auto& kv : map) {
      std::string k;
      try {
        k = kv.first.as<std::string>();
      } catch (const YAML::Exception&) {
        fail(kv.first, key, "has a key that is not a string");
      }
      if (!allowed.contains(k)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(kv.first, join(key, k), "unknown key (allowed: " + list + ")");
      }
    }
    for (const auto& r : required) {
      if (!map[r]) fail(map, join(key, r), "missing required key");
    }
  }

  static std::string join(const std::string& parent, const std::string& child) {
    return parent.empty() ? child : parent + "." + child;
  }

  double number(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) fail(node, key, "must be a number");
    double v = 0.0;
    try {
      v = node.as<double>();
    } catch (const YAML::Exception&) {
      fail(node, key, "must be a number, got '" + node.Scalar() + "'");
    }
    if (!std::isfinite(v)) fail(node, key, "must be finite, got " + node.Scalar());
    return v;
  }

  double positive(const YAML::Node& node, const std::string& key) const {
    const double v = number(node, key);
    if (!(v > 0.0)) fail(node, key, "must be > 0, got " + formatNumber(v));
    return v;
  }

  std::string string(const YAML::Node& node, const std::string& key) const {
    if (!node.IsScalar()) fail(node, key, "must be a string");
    return node.Scalar();
  }

  template <int N>
  Eigen::Matrix<double, N, 1> vector(const YAML::Node& node, const std::string& key) const {
    if (!node.IsSequence() || node.size() != static_cast<std::size_t>(N))
      fail(node, key, "must be a list of " + std::to_string(N) + " numbers");
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) v[i] = number(node[static_cast<std::size_t>(i)], key + "[" + std::to_string(i) + "]");
    return v;
  }

  geometry::Pose3 pose(const YAML::Node& node, const std::string& key) const {
    checkKeys(node, key, {"xyz", "rpy_deg"}, {"xyz"});
    const Eigen::Vector3d xyz = vector<3>(node["xyz"], key + ".xyz");
    Eigen::Vector3d rpy_deg = Eigen::Vector3d::Zero();
    if (node["rpy_deg"]) rpy_deg = vector<3>(node["rpy_deg"], key + ".rpy_deg");
    return geometry::poseFromXyzRpy(xyz.x(), xyz.y(), xyz.z(), geometry::deg2rad(rpy_deg.x()),
                                    geometry::deg2rad(rpy_deg.y()), geometry::deg2rad(rpy_deg.z()));
  }

  SceneObject object(const YAML::Node& node, std::size_t index) const {
    const std::string key = "objects[" + std::to_string(index) + "]";
    if (!node.IsMap()) fail(node, key, "must be a mapping");
    if (!node["type"]) fail(node, key + ".type", "missing required key");
    const std::string type = string(node["type"], key + ".type");
    SceneObject o;
    o.where = yaml::location(source_, node);
    o.name = key;
    const std::set<std::string> common = {"type", "pose", "name"};
    auto with = [&](std::set<std::string> extra) {
      extra.insert(common.begin(), common.end());
      return extra;
    };
    if (type == "cylinder") {
      checkKeys(node, key, with({"radius", "length"}), {"pose", "radius", "length"});
      o.type = ObjectType::kCylinder;
      o.radius_m = positive(node["radius"], key + ".radius");
      o.length_m = positive(node["length"], key + ".length");
    } else if (type == "box") {
      checkKeys(node, key, with({"size"}), {"pose", "size"});
      o.type = ObjectType::kBox;
      o.size_m = vector<3>(node["size"], key + ".size");
      for (int i = 0; i < 3; ++i)
        if (!(o.size_m[i] > 0.0))
          fail(node["size"], key + ".size", "every extent must be > 0, got " + formatNumber(o.size_m[i]));
    } else if (type == "plane") {
      checkKeys(node, key, with({"size"}), {"pose", "size"});
      o.type = ObjectType::kPlane;
      const Eigen::Vector2d s = vector<2>(node["size"], key + ".size");
      for (int i = 0; i < 2; ++i)
        if (!(s[i] > 0.0)) fail(node["size"], key + ".size", "every extent must be > 0, got " + formatNumber(s[i]));
      o.size_m = Eigen::Vector3d(s.x(), s.y(), 0.0);
    } else if (type == "tank") {
      checkKeys(node, key, with({"radius", "height"}), {"pose", "radius", "height"});
      o.type = ObjectType::kTank;
      o.radius_m = positive(node["radius"], key + ".radius");
      o.height_m = positive(node["height"], key + ".height");
    } else if (type == "mesh") {
      checkKeys(node, key, with({"file", "scale"}), {"pose", "file"});
      o.type = ObjectType::kMesh;
      const std::filesystem::path rel = string(node["file"], key + ".file");
      o.mesh_file = rel.is_absolute() ? rel : base_dir_ / rel;
      std::error_code ec;
      if (!std::filesystem::is_regular_file(o.mesh_file, ec))
        fail(node["file"], key + ".file", "mesh file not found: " + o.mesh_file.string());
      if (node["scale"]) o.scale = positive(node["scale"], key + ".scale");
    } else {
      fail(node["type"], key + ".type", "unknown object type '" + type + "' (cylinder, box, plane, tank, mesh)");
    }
    o.T_world_object = pose(node["pose"], key + ".pose");
    if (node["name"]) o.name = string(node["name"], key + ".name");
    return o;
  }

  Scene scene(const YAML::Node& root) const {
    if (!root.IsMap()) fail(root, "(top level)", "must be a mapping with name, bounds, start, objects");
    checkKeys(root, "", {"name", "description", "bounds", "start", "objects"}, {"name", "bounds", "start", "objects"});
    Scene s;
    s.name = string(root["name"], "name");
    if (root["description"]) (void)string(root["description"], "description");

    const YAML::Node b = root["bounds"];
    checkKeys(b, "bounds", {"min", "max"}, {"min", "max"});
    const Eigen::Vector3d lo = vector<3>(b["min"], "bounds.min");
    const Eigen::Vector3d hi = vector<3>(b["max"], "bounds.max");
    for (int i = 0; i < 3; ++i) {
      if (!(hi[i] > lo[i]))
        fail(b, "bounds",
             "max must exceed min on every axis, axis " + std::to_string(i) + ": min " + formatNumber(lo[i]) +
                 ", max " + formatNumber(hi[i]));
    }
    s.bounds_world = Eigen::AlignedBox3d(lo, hi);

    const YAML::Node st = root["start"];
    checkKeys(st, "start", {"xyz", "yaw_deg"}, {"xyz"});
    const Eigen::Vector3d xyz = vector<3>(st["xyz"], "start.xyz");
    const double yaw_deg = st["yaw_deg"] ? number(st["yaw_deg"], "start.yaw_deg") : 0.0;
    if (!s.bounds_world.contains(xyz)) fail(st["xyz"], "start.xyz", "start position is outside bounds");
    s.T_world_start = geometry::poseFromXyzRpy(xyz.x(), xyz.y(), xyz.z(), 0.0, 0.0, geometry::deg2rad(yaw_deg));

    const YAML::Node objs = root["objects"];
    if (!objs.IsSequence()) fail(objs, "objects", "must be a list");
    for (std::size_t i = 0; i < objs.size(); ++i) s.objects.push_back(object(objs[i], i));
    return s;
  }

 private:
  std::string source_;
  std::filesystem::path base_dir_;
};

}  // namespace

Result<Scene> parseScene(const std::string& yaml_text, const std::string& source_name,
                         const std::filesystem::path& base_dir) {
  auto root = yaml::parseDocument(yaml_text, source_name);
  if (!root) return root.error();
  try {
    Parser parser(source_name, base_dir);
    return parser.scene(root.value());
  } catch (const ParseFailure& f) {
    return Error{f.message};
  } catch (const YAML::Exception& e) {
    return Error{source_name + ": YAML error: " + std::string(e.what())};
  }
}

Result<Scene> loadScene(const std::filesystem::path& file) {
  auto text = yaml::readText(file, "scene file");
  if (!text) return text.error();
  auto scene = parseScene(text.value(), file.string(), file.parent_path());
  if (scene.ok()) scene->source_file = file;
  return scene;
}

}  // namespace vog::sim
