// The page's messages: voxel blocks decode to what the merged map holds, cut where asked; commands
// from the page are checked and named when wrong.
#include "vog/console/page_messages.hpp"

#include <gtest/gtest.h>

#include <cstring>

namespace vog::console {
namespace {

// A reader of the binary format as client/console/README.md specifies it (the page's decoder does the same).
struct Decoded {
  std::uint32_t flags = 0;
  double resolution = 0.0;
  double version = 0.0;
  std::uint32_t total_occupied = 0;
  std::vector<std::pair<BlockKey, BlockVoxels>> blocks;
};

Decoded decode(const std::string& m) {
  Decoded d;
  std::size_t at = 0;
  const auto u32 = [&] {
    std::uint32_t v = 0;
    std::memcpy(&v, m.data() + at, 4);
    at += 4;
    return v;
  };
  const auto u16 = [&] {
    std::uint16_t v = 0;
    std::memcpy(&v, m.data() + at, 2);
    at += 2;
    return v;
  };
  const auto f64 = [&] {
    double v = 0;
    std::memcpy(&v, m.data() + at, 8);
    at += 8;
    return v;
  };
  EXPECT_EQ(u32(), kVoxelMagic);
  d.flags = u32();
  d.resolution = f64();
  d.version = f64();
  const std::uint32_t n = u32();
  d.total_occupied = u32();
  for (std::uint32_t b = 0; b < n; ++b) {
    BlockKey key;
    key.x() = static_cast<std::int32_t>(u32());
    key.y() = static_cast<std::int32_t>(u32());
    key.z() = static_cast<std::int32_t>(u32());
    BlockVoxels v;
    const std::uint16_t n_occ = u16();
    const std::uint16_t n_free = u16();
    for (int i = 0; i < n_occ; ++i) v.occupied.push_back(u16());
    for (int i = 0; i < n_free; ++i) v.free.push_back(u16());
    if ((n_occ + n_free) % 2 == 1) at += 2;
    EXPECT_EQ(at % 4, 0u);
    d.blocks.emplace_back(key, std::move(v));
  }
  EXPECT_EQ(at, m.size());
  return d;
}

TEST(VoxelMessages, DecodeToTheBlocksAndAreCutAtTheVoxelLimit) {
  std::vector<std::pair<BlockKey, BlockVoxels>> blocks;
  for (int b = 0; b < 40; ++b) {
    BlockVoxels v;
    for (int i = 0; i < 512; i += 3 + b % 5)
      ((i / 3) % 4 == 0 ? v.occupied : v.free).push_back(static_cast<std::uint16_t>(i));
    blocks.emplace_back(BlockKey(b - 20, -b, 3 * b - 7), std::move(v));
  }
  blocks.emplace_back(BlockKey(100, 100, 100), BlockVoxels{});  // a removed block
  std::vector<std::pair<BlockKey, const BlockVoxels*>> refs;
  for (const auto& [k, v] : blocks) refs.emplace_back(k, &v);

  const auto messages = encodeVoxelMessages(refs, 0.095, 42, true, true, 1234, 1000);
  ASSERT_GT(messages.size(), 3u);
  std::size_t next = 0;
  for (std::size_t m = 0; m < messages.size(); ++m) {
    const Decoded d = decode(messages[m]);
    EXPECT_EQ(d.flags, m == 0 ? kVoxelFlagReset : 0u);
    EXPECT_EQ(d.resolution, 0.095);
    EXPECT_EQ(d.version, 42.0);
    EXPECT_EQ(d.total_occupied, 1234u);
    std::size_t voxels = 0;
    for (const auto& [key, v] : d.blocks) {
      ASSERT_LT(next, blocks.size());
      EXPECT_EQ(key, blocks[next].first);
      EXPECT_EQ(v.occupied, blocks[next].second.occupied);
      EXPECT_EQ(v.free, blocks[next].second.free);
      voxels += v.occupied.size() + v.free.size();
      ++next;
    }
    EXPECT_TRUE(voxels <= 1000 || d.blocks.size() == 1) << "message " << m << " holds " << voxels;
  }
  EXPECT_EQ(next, blocks.size());

  // Without free space: the same blocks, no free indices.
  const Decoded occupied_only = decode(encodeVoxelMessages(refs, 0.095, 42, false, false, 1234, 1u << 20).at(0));
  ASSERT_EQ(occupied_only.blocks.size(), blocks.size());
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    EXPECT_EQ(occupied_only.blocks[i].second.occupied, blocks[i].second.occupied);
    EXPECT_TRUE(occupied_only.blocks[i].second.free.empty());
  }
  // Nothing to send is still one (empty) message.
  EXPECT_EQ(decode(encodeVoxelMessages({}, 0.1, 1, false, false, 0, 100).at(0)).blocks.size(), 0u);
}

TEST(VoxelMessages, ABlockIsClassifiedAsTheMergedMapQueriesIt) {
  map::GridConfig config;
  auto merged = map::MergedMap::create(config).value();
  auto grid = map::LocalGrid::create(config).value();
  std::vector<map::BeamEnd> beams;
  for (int i = 0; i < 60; ++i) beams.push_back({Eigen::Vector3d(2.0, -1.5 + 0.05 * i, 0.1 * (i % 7)), i % 4 != 0});
  ASSERT_TRUE(grid->insertRays(Eigen::Vector3d::Zero(), beams).ok());
  grid->finalize();
  map::SubmapEntry entry;
  entry.grid = std::move(grid);
  ASSERT_TRUE(merged->add(entry).ok());
  const map::LogOddsBounds bounds = config.bounds();
  std::size_t occupied = 0;
  std::size_t free = 0;
  for (const auto& [origin, block] : merged->blocksChangedSince(0)) {
    const BlockVoxels v = classifyBlock(*block, bounds);
    for (const std::uint16_t i : v.occupied) {
      const map::VoxelKey k = origin + map::VoxelKey(i & 7, (i >> 3) & 7, i >> 6);
      EXPECT_EQ(merged->at(k).status, map::Occupancy::kOccupied);
    }
    for (const std::uint16_t i : v.free) {
      const map::VoxelKey k = origin + map::VoxelKey(i & 7, (i >> 3) & 7, i >> 6);
      EXPECT_EQ(merged->at(k).status, map::Occupancy::kFree);
    }
    occupied += v.occupied.size();
    free += v.free.size();
  }
  EXPECT_GT(occupied, 10u);
  EXPECT_EQ(occupied + free, merged->knownVoxelCount());
}

TEST(PageCommands, AreCheckedAndNamedWhenWrong) {
  const auto error = [](std::string_view text) {
    const auto r = parsePageMessage(text);
    return std::holds_alternative<PageError>(r) ? std::get<PageError>(r).text : std::string("(accepted)");
  };
  EXPECT_EQ(error("not json"), "the message is not JSON");
  EXPECT_EQ(error("[1, 2]"), "the message is not a JSON object");
  EXPECT_EQ(error(R"({"type": "fly"})"), "unknown message type \"fly\"");
  EXPECT_EQ(error(R"({"type": "command", "id": 3, "command": "fly_to_the_moon"})"),
            "unknown command \"fly_to_the_moon\"");
  EXPECT_EQ(error(R"({"type": "command", "command": "start"})"), "command: \"id\" must be an integer");
  EXPECT_EQ(error(R"({"type": "command", "id": 4, "command": "set_box"})"), "set_box needs a box");
  EXPECT_EQ(error(R"({"type": "command", "id": 5, "command": "pause", "box": {"min": [0,0,0], "max": [1,1,1]}})"),
            "pause takes no box");
  EXPECT_NE(error(R"({"type": "command", "id": 6, "command": "start", "box": {"min": [0,0,0], "max": [1,-1,1]}})")
                .find("box: "),
            std::string::npos);
  EXPECT_EQ(error(R"({"type": "view", "free": "yes"})"), "view: \"free\" must be true or false");
  // The id comes back with the error, so the page can match the reply.
  const auto unknown = parsePageMessage(R"({"type": "command", "id": 77, "command": "dive"})");
  ASSERT_TRUE(std::holds_alternative<PageError>(unknown));
  EXPECT_EQ(std::get<PageError>(unknown).id, 77);

  // Start with a box: set-box, then start.
  const auto start = parsePageMessage(
      R"({"type": "command", "id": 9, "command": "start", "box": {"min": [-6,-4,-4], "max": [6,4,0]}})");
  ASSERT_TRUE(std::holds_alternative<PageMessage>(start));
  const PageCommand& c = *std::get<PageMessage>(start).command;
  EXPECT_EQ(c.id, 9);
  ASSERT_EQ(c.commands.size(), 2u);
  EXPECT_EQ(c.commands[0].kind, api::MissionCommand::Kind::kSetBox);
  EXPECT_EQ(c.commands[0].box.min_world_m, Eigen::Vector3d(-6, -4, -4));
  EXPECT_EQ(c.commands[1].kind, api::MissionCommand::Kind::kStart);
  const auto view = parsePageMessage(R"({"type": "view", "free": true})");
  ASSERT_TRUE(std::holds_alternative<PageMessage>(view));
  EXPECT_TRUE(std::get<PageMessage>(view).view->free);
}

}  // namespace
}  // namespace vog::console
