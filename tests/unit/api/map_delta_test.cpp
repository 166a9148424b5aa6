#include "vog/api/map_delta.hpp"

#include "api_test_support.hpp"
#include "map_fixtures.hpp"
#include "vog/v1/map.pb.h"

#include <gtest/gtest.h>

namespace vog::api {
namespace {

using test::expectMirrorEquals;

// Sends the delta through its wire form, as the API does.
v1::MapDelta overTheWire(const v1::MapDelta& delta) {
  std::string bytes;
  EXPECT_TRUE(delta.SerializeToString(&bytes));
  v1::MapDelta received;
  EXPECT_TRUE(received.ParseFromString(bytes));
  return received;
}

TEST(MapDelta, AMirrorFollowsTheMapThroughDeltas) {
  const map::GridConfig config;
  const auto built = map::test_fixtures::buildSubmaps(config, 5, 20, 2, 4.0);
  std::vector<map::SubmapEntry> entries;
  for (std::size_t i = 0; i < built.size(); ++i) {
    entries.push_back(
        {static_cast<map::SubmapId>(i), built[i].grid, built[i].T_world_submap, built[i].T_world_submap.inverse()});
  }
  auto merged = map::MergedMap::create(config).value();
  for (std::size_t i = 0; i < 3; ++i) ASSERT_TRUE(merged->add(entries[i]).ok());

  MapMirror mirror;
  ASSERT_TRUE(mirror.apply(overTheWire(encodeMapDelta(*merged->snapshot(), 0))).ok());
  expectMirrorEquals(mirror, *merged);

  // A loop closure moves submap 0, two more submaps arrive: the next delta holds only what changed.
  const std::uint64_t seen = merged->version();
  ASSERT_TRUE(merged->remove(0).ok());
  entries[0].T_world_submap = geometry::poseFromXyzRpy(0.3, 0.2, 0.0, 0, 0, 0.1) * entries[0].T_world_submap;
  entries[0].T_submap_world = entries[0].T_world_submap.inverse();
  for (std::size_t i : {std::size_t{0}, std::size_t{3}, std::size_t{4}}) ASSERT_TRUE(merged->add(entries[i]).ok());
  const v1::MapDelta delta = encodeMapDelta(*merged->snapshot(), seen);
  EXPECT_LT(static_cast<std::size_t>(delta.changed_size()), merged->blockCount());
  ASSERT_TRUE(mirror.apply(overTheWire(delta)).ok());
  expectMirrorEquals(mirror, *merged);

  // Submap 2 leaves for good: the delta names the blocks only it covered, a full map names none (there
  // is nothing to remove from an empty copy) and still builds the same map.
  const std::uint64_t before_removal = merged->version();
  ASSERT_TRUE(merged->remove(2).ok());
  const v1::MapDelta after_removal = encodeMapDelta(*merged->snapshot(), before_removal);
  EXPECT_GT(after_removal.removed_size(), 0);
  ASSERT_TRUE(mirror.apply(overTheWire(after_removal)).ok());
  expectMirrorEquals(mirror, *merged);
  const v1::MapDelta full = encodeMapDelta(*merged->snapshot(), 0);
  EXPECT_EQ(full.removed_size(), 0);
  MapMirror fresh;
  ASSERT_TRUE(fresh.apply(overTheWire(full)).ok());
  expectMirrorEquals(fresh, *merged);
}

TEST(MapDelta, MirrorRejectsOutOfOrderAndMalformedDeltas) {
  MapMirror mirror;
  v1::MapDelta delta;
  delta.mutable_grid()->set_resolution_m(0.1);
  delta.set_since_version(5);
  delta.set_version(6);
  const Status gap = mirror.apply(delta);
  ASSERT_FALSE(gap.ok());
  EXPECT_NE(gap.error().message.find("version 5"), std::string::npos);

  delta.set_since_version(0);
  auto* block = delta.add_changed();
  block->set_known(std::string(10, '\0'));
  block->set_log_odds(std::string(2048, '\0'));
  const Status bad = mirror.apply(delta);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("10 known bytes"), std::string::npos);
  EXPECT_EQ(mirror.version(), 0u);
  EXPECT_EQ(mirror.blockCount(), 0u);

  block->set_known(std::string(64, '\0'));
  block->set_origin_x(3);
  EXPECT_FALSE(mirror.apply(delta).ok());
  delta.mutable_grid()->set_resolution_m(std::numeric_limits<double>::quiet_NaN());
  block->set_origin_x(8);
  EXPECT_FALSE(mirror.apply(delta).ok());
  EXPECT_EQ(mirror.blockCount(), 0u);
}

}  // namespace
}  // namespace vog::api
