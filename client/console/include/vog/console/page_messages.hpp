#pragma once
// The messages between vog-console and its page (client/console/README.md "The page's protocol"):
// JSON built from the API's domain types, the binary voxel blocks of the merged map, and the page's
// commands parsed and checked.

#include "vog/api/domain.hpp"
#include "vog/api/graph.hpp"
#include "vog/map/merged_map.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace vog::console {

using Json = nlohmann::json;

inline constexpr std::uint32_t kVoxelMagic = 0x314C5856;  // "VXL1"
inline constexpr std::uint32_t kVoxelFlagReset = 1;

// One 8 x 8 x 8 block as the page holds it: the indices (x + 8 y + 64 z) of its occupied and free voxels.
struct BlockVoxels {
  std::vector<std::uint16_t> occupied;
  std::vector<std::uint16_t> free;
  bool empty() const { return occupied.empty() && free.empty(); }
};
using BlockKey = map::VoxelKey;  // block coordinates (voxel key >> 3)
struct BlockKeyLess {
  bool operator()(const BlockKey& a, const BlockKey& b) const {
    if (a.x() != b.x()) return a.x() < b.x();
    if (a.y() != b.y()) return a.y() < b.y();
    return a.z() < b.z();
  }
};
using BlockMap = std::map<BlockKey, BlockVoxels, BlockKeyLess>;

// A block of a merged map classified as the page shows it (clamped log-odds, occupied above the threshold).
BlockVoxels classifyBlock(const map::MergedMap::Block& block, const map::LogOddsBounds& bounds);

// Binary voxel messages of `blocks` (an empty BlockVoxels removes the block), cut so that each message
// holds at most `max_voxels` voxels (at least one block each). `reset` marks the first message.
// `with_free` false leaves the free indices out. `total_occupied` is the whole map's count after them.
std::vector<std::string> encodeVoxelMessages(const std::vector<std::pair<BlockKey, const BlockVoxels*>>& blocks,
                                             double resolution_m, std::uint64_t map_version, bool reset, bool with_free,
                                             std::uint64_t total_occupied, std::size_t max_voxels);

Json poseJson(const geometry::Pose3& T);  // {p: [x,y,z], q: [w,x,y,z]}
Json statusJson(const api::StatusReport& status);
Json graphJson(const api::GraphUpdate& update);
Json waypointJson(const api::Waypoint& waypoint);

// A command from the page: {"type": "command", "id": N, "command": C, "box": {...}}.
struct PageCommand {
  std::int64_t id = 0;
  std::vector<api::MissionCommand> commands;  // start with a box: set-box, then start
};
// A message from the page: a command, or a view setting ({"type": "view", "free": bool}).
struct PageView {
  bool free = false;
};
struct PageMessage {
  std::optional<PageCommand> command;
  std::optional<PageView> view;
};
// Parses and checks one text frame; the error says what was wrong (not JSON, unknown type or
// command, a bad box), and carries the command's id when it had one.
struct PageError {
  std::string text;
  std::optional<std::int64_t> id;
};
std::variant<PageMessage, PageError> parsePageMessage(std::string_view text);

}  // namespace vog::console
