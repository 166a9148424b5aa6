// The YAML reader's shared pieces: a syntax error and an error about a value both name file:line.
#include "vog/yaml/config_reader.hpp"

#include <gtest/gtest.h>

namespace vog::yaml {
namespace {

TEST(Yaml, SyntaxErrorNamesFileAndLine) {
  auto doc = parseDocument("a: 1\nb: [1, 2\n", "f.yaml");
  ASSERT_FALSE(doc.ok());
  EXPECT_EQ(doc.error().message.rfind("f.yaml:", 0), 0U) << doc.error().message;
  EXPECT_NE(doc.error().message.find("YAML syntax error"), std::string::npos) << doc.error().message;
}

TEST(Yaml, ErrorAboutAValueNamesItsLineAndKey) {
  auto doc = parseDocument("a: 1\nb:\n  c: x\n", "f.yaml");
  ASSERT_TRUE(doc.ok()) << doc.error().message;
  const YAML::Node c = doc.value()["b"]["c"];
  EXPECT_EQ(location("f.yaml", c), "f.yaml:3");
  EXPECT_EQ(errorAt("f.yaml", c, "b.c", "must be a number").message, "f.yaml:3: b.c: must be a number");
  EXPECT_EQ(location("f.yaml", YAML::Node()), "f.yaml:0");  // a node that is not in the file
}

TEST(Yaml, ConfigReaderUsesTheSameForm) {
  auto reader = ConfigReader::parse("grid:\n  resolution_m: 5\n", "g.yaml");
  ASSERT_TRUE(reader.ok());
  double resolution_m = 0.1;
  ConfigMap grid = (*reader)->root().map("grid");
  grid.number("resolution_m", resolution_m, 0.01, 1.0);
  ASSERT_FALSE((*reader)->status().ok());
  EXPECT_EQ((*reader)->status().error().message, "g.yaml:2: grid.resolution_m: must be in [0.01, 1], got 5");
  EXPECT_EQ(resolution_m, 0.1);
}

}  // namespace
}  // namespace vog::yaml
