#pragma once
// Helper of the simulator tests: a World from the YAML text of its objects (the rest of the scene
// fixed), failing the test when the text is rejected.

#include "vog/sim/world.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <string>

namespace vog::sim {

inline std::unique_ptr<World> worldFrom(const std::string& objects,
                                        const std::string& bounds = "{min: [-10, -10, -10], max: [10, 10, 10]}",
                                        const std::filesystem::path& dir = ".") {
  const std::string text = "name: t\nbounds: " + bounds + "\nstart: {xyz: [0, 0, 0]}\nobjects:\n" + objects;
  auto s = parseScene(text, "t.yaml", dir);
  EXPECT_TRUE(s.ok()) << s.error().message;
  auto w = World::create(*s);
  EXPECT_TRUE(w.ok()) << w.error().message;
  return std::move(w).value();
}

}  // namespace vog::sim
