#include "vog/console/page_messages.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <cstring>

namespace vog::console {

namespace {

void putU32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
void putI32(std::string& out, std::int32_t v) { putU32(out, static_cast<std::uint32_t>(v)); }
void putU16(std::string& out, std::uint16_t v) {
  out.push_back(static_cast<char>(v & 0xff));
  out.push_back(static_cast<char>(v >> 8));
}
void putF64(std::string& out, double v) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<char>((bits >> (8 * i)) & 0xff));
}

Json vec3(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

Json boxJson(const api::ExplorationBox& box) {
  return {{"min", vec3(box.min_world_m)}, {"max", vec3(box.max_world_m)}};
}

}  // namespace

BlockVoxels classifyBlock(const map::MergedMap::Block& block, const map::LogOddsBounds& bounds) {
  BlockVoxels out;
  for (std::size_t i = 0; i < block.packed.size(); ++i) {
    if (block.count(i) == 0) continue;
    const bool occupied = bounds.classify(bounds.clamp(block.sum(i))) == map::Occupancy::kOccupied;
    (occupied ? out.occupied : out.free).push_back(static_cast<std::uint16_t>(i));
  }
  return out;
}

std::vector<std::string> encodeVoxelMessages(const std::vector<std::pair<BlockKey, const BlockVoxels*>>& blocks,
                                             double resolution_m, std::uint64_t map_version, bool reset, bool with_free,
                                             std::uint64_t total_occupied, std::size_t max_voxels) {
  std::vector<std::string> out;
  std::size_t at = 0;
  do {
    std::string m;
    putU32(m, kVoxelMagic);
    putU32(m, out.empty() && reset ? kVoxelFlagReset : 0);
    putF64(m, resolution_m);
    putF64(m, static_cast<double>(map_version));
    const std::size_t n_blocks_at = m.size();
    putU32(m, 0);  // n_blocks, filled below
    putU32(m, static_cast<std::uint32_t>(total_occupied));
    std::uint32_t n_blocks = 0;
    std::size_t voxels = 0;
    for (; at < blocks.size(); ++at) {
      const BlockVoxels& b = *blocks[at].second;
      const std::size_t n_free = with_free ? b.free.size() : 0;
      const std::size_t n = b.occupied.size() + n_free;
      if (n_blocks > 0 && voxels + n > max_voxels) break;
      putI32(m, blocks[at].first.x());
      putI32(m, blocks[at].first.y());
      putI32(m, blocks[at].first.z());
      putU16(m, static_cast<std::uint16_t>(b.occupied.size()));
      putU16(m, static_cast<std::uint16_t>(n_free));
      for (const std::uint16_t i : b.occupied) putU16(m, i);
      for (std::size_t k = 0; k < n_free; ++k) putU16(m, b.free[k]);
      if (n % 2 == 1) putU16(m, 0);
      ++n_blocks;
      voxels += n;
    }
    for (int i = 0; i < 4; ++i)
      m[n_blocks_at + static_cast<std::size_t>(i)] = static_cast<char>((n_blocks >> (8 * i)) & 0xff);
    out.push_back(std::move(m));
  } while (at < blocks.size());
  return out;
}

Json poseJson(const geometry::Pose3& T) {
  const Eigen::Quaterniond q(T.linear());
  return {{"p", vec3(T.translation())}, {"q", Json::array({q.w(), q.x(), q.y(), q.z()})}};
}

Json statusJson(const api::StatusReport& s) {
  Json devices = Json::array();
  for (const api::DeviceHealth& d : s.devices) {
    devices.push_back({{"name", d.name},
                       {"state", api::toString(d.state)},
                       {"detail", d.detail},
                       {"messages", d.messages},
                       {"errors", d.errors}});
  }
  return {{"type", "status"},
          {"mission_state", api::toString(s.mission_state)},
          {"planner_state", api::toString(s.planner_state)},
          {"n_submaps", s.n_submaps},
          {"n_closures", s.n_closures},
          {"map_version", s.map_version},
          {"graph_version", s.graph_version},
          {"stamp_ns", s.stamp_ns},
          {"pose", poseJson(s.T_world_vehicle)},
          {"sigma_xyz_m", vec3(s.sigma_xyz_m)},
          {"sigma_yaw_rad", s.sigma_yaw_rad},
          {"devices", std::move(devices)},
          {"box", s.box ? boxJson(*s.box) : Json(nullptr)}};
}

Json graphJson(const api::GraphUpdate& u) {
  Json submaps = Json::array();
  for (const api::SubmapPose& p : u.submaps) {
    Json j = poseJson(p.T_world_submap);
    j["id"] = p.id;
    submaps.push_back(std::move(j));
  }
  Json closures = Json::array();
  for (const api::ClosurePair& c : u.closures) closures.push_back(Json::array({c.from, c.to}));
  return {{"type", "graph"},
          {"version", u.version},
          {"full", u.full},
          {"submaps", std::move(submaps)},
          {"closures", std::move(closures)}};
}

Json waypointJson(const api::Waypoint& w) {
  Json j = poseJson(w.T_world_target);
  j["type"] = "waypoint";
  j["seq"] = w.seq;
  j["speed_mps"] = w.speed_mps;
  return j;
}

std::variant<PageMessage, PageError> parsePageMessage(std::string_view text) {
  const Json j = Json::parse(text, nullptr, false);
  if (j.is_discarded()) return PageError{"the message is not JSON", std::nullopt};
  if (!j.is_object()) return PageError{"the message is not a JSON object", std::nullopt};
  const auto type = j.find("type");
  if (type == j.end() || !type->is_string()) return PageError{"the message has no \"type\" string", std::nullopt};
  if (*type == "view") {
    const auto free = j.find("free");
    if (free == j.end() || !free->is_boolean()) return PageError{"view: \"free\" must be true or false", std::nullopt};
    return PageMessage{std::nullopt, PageView{free->get<bool>()}};
  }
  if (*type != "command") return PageError{"unknown message type \"" + type->get<std::string>() + "\"", std::nullopt};
  const auto id_it = j.find("id");
  if (id_it == j.end() || !id_it->is_number_integer())
    return PageError{"command: \"id\" must be an integer", std::nullopt};
  PageCommand out;
  out.id = id_it->get<std::int64_t>();
  const auto name_it = j.find("command");
  if (name_it == j.end() || !name_it->is_string()) return PageError{"command: \"command\" must be a string", out.id};
  const std::string name = name_it->get<std::string>();
  using K = api::MissionCommand::Kind;
  static const std::map<std::string, K> kinds = {{"set_box", K::kSetBox}, {"start", K::kStart},
                                                 {"pause", K::kPause},    {"resume", K::kResume},
                                                 {"abort", K::kAbort},    {"return_home", K::kReturnHome}};
  const auto kind = kinds.find(name);
  if (kind == kinds.end()) return PageError{"unknown command \"" + name + "\"", out.id};
  const auto box_it = j.find("box");
  const bool takes_box = kind->second == K::kSetBox || kind->second == K::kStart;
  if (box_it != j.end() && !box_it->is_null()) {
    if (!takes_box) return PageError{name + " takes no box", out.id};
    api::MissionCommand set;
    set.kind = K::kSetBox;
    const char* corners[2] = {"min", "max"};
    for (int c = 0; c < 2; ++c) {
      const auto v = box_it->find(corners[c]);
      if (!box_it->is_object() || v == box_it->end() || !v->is_array() || v->size() != 3) {
        return PageError{std::string("box.") + corners[c] + " must be [x, y, z]", out.id};
      }
      for (int k = 0; k < 3; ++k) {
        if (!(*v)[static_cast<std::size_t>(k)].is_number()) {
          return PageError{std::string("box.") + corners[c] + " must hold numbers", out.id};
        }
        (c == 0 ? set.box.min_world_m : set.box.max_world_m)[k] = (*v)[static_cast<std::size_t>(k)].get<double>();
      }
    }
    if (Status st = set.box.validate(); !st) return PageError{"box: " + st.error().message, out.id};
    out.commands.push_back(set);
  } else if (kind->second == K::kSetBox) {
    return PageError{"set_box needs a box", out.id};
  }
  if (kind->second != K::kSetBox) {
    api::MissionCommand c;
    c.kind = kind->second;
    out.commands.push_back(c);
  }
  return PageMessage{out, std::nullopt};
}

}  // namespace vog::console
