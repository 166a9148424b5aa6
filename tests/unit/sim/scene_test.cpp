#include "vog/geometry/sonar.hpp"
#include "vog/sim/scene.hpp"
#include "vog/sim/world.hpp"

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <fstream>

namespace vog::sim {
namespace {

std::filesystem::path scenesDir() { return vog::test::sourceDir() / "config" / "scenes"; }

// A valid scene; tests replace one line to make it bad.
std::string validScene() {
  return "name: t\n"                                                                                    // line 1
         "bounds: {min: [-6, -4, -4], max: [6, 4, 0]}\n"                                                // line 2
         "start: {xyz: [-5, 0, -1.5], yaw_deg: 0}\n"                                                    // line 3
         "objects:\n"                                                                                   // line 4
         "  - {type: cylinder, pose: {xyz: [0, 0, -3], rpy_deg: [5, 0, 0]}, radius: 0.3, length: 6}\n"  // line 5
         "  - {type: box, pose: {xyz: [2, 1, -3.5], rpy_deg: [0, 0, 30]}, size: [1.0, 0.6, 0.5]}\n"     // line 6
         "  - {type: plane, pose: {xyz: [0, 0, -4], rpy_deg: [0, 0, 0]}, size: [14, 10]}\n"             // line 7
         "  - {type: tank, pose: {xyz: [0, 0, -3], rpy_deg: [0, 0, 0]}, radius: 3.5, height: 3}\n";     // line 8
}

std::string replaceLine(const std::string& text, int line, const std::string& replacement) {
  std::string out;
  int n = 1;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    const std::string l = text.substr(start, end - start);
    out += (n == line ? replacement : l) + "\n";
    start = end + 1;
    ++n;
  }
  return out;
}

TEST(Scene, ParsesTheIssueSchema) {
  auto s = parseScene(validScene(), "t.yaml", ".");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->name, "t");
  ASSERT_EQ(s->objects.size(), 4u);
  EXPECT_EQ(s->objects[0].type, ObjectType::kCylinder);
  EXPECT_DOUBLE_EQ(s->objects[0].radius_m, 0.3);
  EXPECT_DOUBLE_EQ(s->objects[0].length_m, 6.0);
  EXPECT_NEAR(geometry::rpyFromRotation(s->objects[0].T_world_object.linear()).x(), geometry::deg2rad(5.0), 1e-12);
  EXPECT_EQ(s->objects[1].size_m, Eigen::Vector3d(1.0, 0.6, 0.5));
  EXPECT_EQ(s->objects[3].type, ObjectType::kTank);
  EXPECT_EQ(s->bounds_world.min(), Eigen::Vector3d(-6, -4, -4));
  EXPECT_EQ(s->T_world_start.translation(), Eigen::Vector3d(-5, 0, -1.5));
}

TEST(Scene, ShippedScenesLoadAndBuildWithAStartClearOfObstacles) {
  for (const char* name :
       {"pilings.yaml", "propeller.yaml", "tank.yaml", "harbour.yaml", "hull.yaml", "slanted-pier.yaml"}) {
    auto s = loadScene(scenesDir() / name);
    ASSERT_TRUE(s.ok()) << name << ": " << s.error().message;
    auto w = World::create(*s);
    ASSERT_TRUE(w.ok()) << name << ": " << w.error().message;
    EXPECT_FALSE((*w)->boxCollides(s->T_world_start, Eigen::Vector3d(0.5, 0.5, 0.25))) << name;
  }
}

TEST(Scene, PropellerIsRoughlySevenByFourBySixMetres) {
  auto s = loadScene(scenesDir() / "propeller.yaml");
  ASSERT_TRUE(s.ok()) << s.error().message;
  auto w = World::create(*s);
  ASSERT_TRUE(w.ok()) << w.error().message;
  Eigen::AlignedBox3d box;
  for (const auto& p : (*w)->sampleSurface(0.05, 1).points)
    if (p.z() > -11.0) box.extend(p);  // leave out the seabed
  const Eigen::Vector3d size = box.sizes();
  EXPECT_NEAR(size.x(), 7.0, 1.0);
  EXPECT_NEAR(size.y(), 4.0, 1.0);
  EXPECT_NEAR(size.z(), 6.0, 1.0);
}

struct BadCase {
  int line;
  std::string text;
  std::string expect;  // substring of the error
};

TEST(Scene, BadValuesAreRejectedWithFileLineAndKey) {
  const std::vector<BadCase> cases = {
      {5, "  - {type: cylinder, pose: {xyz: [0, 0, -3]}, radius: -0.3, length: 6}",
       "t.yaml:5: objects[0].radius: must be > 0"},
      {5, "  - {type: cylinder, pose: {xyz: [0, 0, -3]}, radius: 0.3, lenght: 6}",
       "t.yaml:5: objects[0].lenght: unknown key"},
      {5, "  - {type: cylinder, pose: {xyz: [0, 0, -3]}, radius: 0.3}", "objects[0].length: missing required key"},
      {5, "  - {type: cylinder, pose: {xyz: [0, 0, -3]}, radius: .nan, length: 6}",
       "t.yaml:5: objects[0].radius: must be finite"},
      {5, "  - {type: cylinder, pose: {xyz: [0, 0]}, radius: 0.3, length: 6}",
       "objects[0].pose.xyz: must be a list of 3 numbers"},
      {5, "  - {type: cylinder, pose: {xyz: [0, a, 0]}, radius: 0.3, length: 6}",
       "objects[0].pose.xyz[1]: must be a number"},
      {6, "  - {type: box, pose: {xyz: [2, 1, -3.5]}, size: [1.0, 0, 0.5]}",
       "t.yaml:6: objects[1].size: every extent must be > 0"},
      {6, "  - {type: sphere, pose: {xyz: [2, 1, -3.5]}, radius: 1}",
       "t.yaml:6: objects[1].type: unknown object type 'sphere'"},
      {7, "  - {type: plane, pose: {xyz: [0, 0, -4]}, size: [14, 10, 3]}",
       "objects[2].size: must be a list of 2 numbers"},
      {8, "  - {type: tank, pose: {xyz: [0, 0, -3]}, radius: 3.5, height: 0}",
       "t.yaml:8: objects[3].height: must be > 0"},
      {8, "  - {type: mesh, pose: {xyz: [0, 0, -2]}, file: no_such_prop.stl}",
       "t.yaml:8: objects[3].file: mesh file not found"},
      {2, "bounds: {min: [-6, -4, -4], max: [6, -5, 0]}", "t.yaml:2: bounds: max must exceed min"},
      {3, "start: {xyz: [-7, 0, -1.5], yaw_deg: 0}", "t.yaml:3: start.xyz: start position is outside bounds"},
      {1, "nam: t", "t.yaml:1: nam: unknown key"},
      {5, "  - {type: cylinder, pose: {xyz: [0, 0, -3], rpy_deg: [5, 0, 0]}, radius: 0.3, length: 6", "t.yaml:"},
  };
  for (const auto& c : cases) {
    auto s = parseScene(replaceLine(validScene(), c.line, c.text), "t.yaml", ".");
    ASSERT_FALSE(s.ok()) << "accepted: " << c.text;
    EXPECT_NE(s.error().message.find(c.expect), std::string::npos)
        << "got: " << s.error().message << "\nexpected: " << c.expect;
  }
}

TEST(Scene, EmptyAndNonMappingInputsAreErrorsNotCrashes) {
  for (const char* text : {"", "[]", "42", "name: [1, 2]\nbounds: 3\nstart: 4\nobjects: 5\n", "\t: :"}) {
    auto s = parseScene(text, "x.yaml", ".");
    EXPECT_FALSE(s.ok()) << "accepted: '" << text << "'";
  }
  EXPECT_FALSE(loadScene("/nonexistent/scene.yaml").ok());
}

TEST(Scene, MeshPathIsRelativeToTheSceneFile) {
  vog::test::TempDir dir("vog-sim-scene");
  std::filesystem::create_directories(dir.path() / "meshes");
  std::filesystem::copy_file(scenesDir() / "propeller_blades.stl", dir.path() / "meshes" / "p.stl");
  std::ofstream(dir.path() / "s.yaml")
      << "name: m\nbounds: {min: [-6, -6, -9], max: [6, 6, 0]}\nstart: {xyz: [0, -5, -1]}\n"
         "objects:\n  - {type: mesh, pose: {xyz: [0, 0, -4.5]}, file: meshes/p.stl, scale: 1.0}\n";
  auto s = loadScene(dir.path() / "s.yaml");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->objects[0].mesh_file, dir.path() / "meshes" / "p.stl");
  EXPECT_TRUE(World::create(*s).ok());
}

TEST(World, UnreadableOrDegenerateMeshesAreClearErrors) {
  vog::test::TempDir dir("vog-sim-mesh");
  std::ofstream(dir.path() / "junk.stl") << "this is not a mesh at all";
  // An ASCII STL whose only facet has zero area.
  std::ofstream(dir.path() / "flat.stl")
      << "solid f\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 2 0 0\n"
         "endloop\nendfacet\nendsolid f\n";
  for (const char* file : {"junk.stl", "flat.stl"}) {
    const std::string text = std::string(
                                 "name: m\nbounds: {min: [-1, -1, -1], max: [1, 1, 1]}\nstart: {xyz: [0, 0, 0]}\n"
                                 "objects:\n  - {type: mesh, pose: {xyz: [0, 0, 0]}, file: ") +
                             file + "}\n";
    auto s = parseScene(text, "m.yaml", dir.path());
    ASSERT_TRUE(s.ok()) << s.error().message;
    auto w = World::create(*s);
    ASSERT_FALSE(w.ok()) << file;
    EXPECT_NE(w.error().message.find("m.yaml:5: objects[0].file"), std::string::npos) << w.error().message;
  }
}

}  // namespace
}  // namespace vog::sim
