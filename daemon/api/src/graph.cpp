#include "vog/api/graph.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <string>

namespace vog::api {

namespace {

// A rotation about z alone: r02, r12, r20, r21 zero (of either sign) and r22 = 1.0. Its pose travels as
// 7 doubles (r00 r01 r10 r11 tx ty tz) and a form: bit 0 set, bits 1-4 the signs of r02, r12, r20, r21
// (set: -0.0), so it is rebuilt bit for bit. Form 0: the 12 doubles.
constexpr int kZeros[4][2] = {{0, 2}, {1, 2}, {2, 0}, {2, 1}};

std::uint32_t poseForm(const geometry::Pose3& T) {
  const auto& m = T.matrix();
  if (m(2, 2) != 1.0) return 0;
  std::uint32_t form = 1;
  for (int k = 0; k < 4; ++k) {
    const double v = m(kZeros[k][0], kZeros[k][1]);
    if (v != 0.0) return 0;
    if (std::signbit(v)) form |= 2u << k;
  }
  return form;
}

bool samePose(const geometry::Pose3& a, const geometry::Pose3& b) {
  return std::memcmp(a.matrix().data(), b.matrix().data(), sizeof(double) * 16) == 0;
}

std::uint64_t bitsOf(double v) { return std::bit_cast<std::uint64_t>(v); }

PoseChange poseChange(std::uint32_t id, const geometry::Pose3& held, const geometry::Pose3& now) {
  PoseChange c;
  c.id = id;
  for (int k = 0; k < 12; ++k) c.bits_xor[k] = bitsOf(held.matrix()(k / 4, k % 4)) ^ bitsOf(now.matrix()(k / 4, k % 4));
  return c;
}

Status checkPose(std::uint32_t id, const geometry::Pose3& T) {
  const auto& m = T.matrix();
  if (!m.allFinite()) return Error{"graph_update: submap " + std::to_string(id) + "'s pose is not finite"};
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  if ((R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || R.determinant() < 0.0) {
    return Error{"graph_update: submap " + std::to_string(id) + "'s pose has no rotation matrix"};
  }
  return {};
}

// A change on the wire: 6 bytes of 12 nibbles (double k in nibble k, low nibble first), each the count of
// leading zero bytes of its XOR (0-8), then each XOR's remaining low bytes, most significant first.
void encodeChange(const PoseChange& c, std::string& out) {
  const std::size_t header = out.size();
  out.append(6, '\0');
  for (int k = 0; k < 12; ++k) {
    const int zeros = std::countl_zero(c.bits_xor[k]) / 8;
    out[header + k / 2] = static_cast<char>(out[header + k / 2] | (zeros << (k % 2 == 0 ? 0 : 4)));
    for (int b = 7 - zeros; b >= 0; --b) out.push_back(static_cast<char>((c.bits_xor[k] >> (8 * b)) & 0xFF));
  }
}

Result<PoseChange> decodeChange(std::uint32_t id, std::string_view bytes, std::size_t& at) {
  PoseChange c;
  c.id = id;
  if (bytes.size() - at < 6) return Error{"graph_update.pose_changes ends inside submap " + std::to_string(id)};
  const std::size_t header = at;
  at += 6;
  for (int k = 0; k < 12; ++k) {
    const int zeros = (static_cast<unsigned char>(bytes[header + k / 2]) >> (k % 2 == 0 ? 0 : 4)) & 0xF;
    if (zeros > 8) {
      return Error{"graph_update.pose_changes: submap " + std::to_string(id) + " says " + std::to_string(zeros) +
                   " leading zero bytes (at most 8)"};
    }
    const auto n = static_cast<std::size_t>(8 - zeros);
    if (bytes.size() - at < n) return Error{"graph_update.pose_changes ends inside submap " + std::to_string(id)};
    std::uint64_t x = 0;
    for (std::size_t b = 0; b < n; ++b) x = (x << 8) | static_cast<unsigned char>(bytes[at++]);
    c.bits_xor[k] = x;
  }
  return c;
}

GraphUpdate fullUpdate(const GraphState& now) {
  GraphUpdate u;
  u.version = now.version;
  u.full = true;
  u.stamp_ns = now.stamp_ns;
  u.submaps = now.submaps;
  u.closures = now.closures;
  u.n_submaps = static_cast<std::uint32_t>(now.submaps.size());
  return u;
}

}  // namespace

GraphUpdate graphUpdate(const GraphState* held, const GraphState& now) {
  if (held == nullptr || held->submaps.size() > now.submaps.size() || held->closures.size() > now.closures.size() ||
      !std::equal(held->closures.begin(), held->closures.end(), now.closures.begin())) {
    return fullUpdate(now);
  }
  GraphUpdate u;
  u.version = now.version;
  u.base_version = held->version;
  u.stamp_ns = now.stamp_ns;
  u.n_submaps = static_cast<std::uint32_t>(now.submaps.size());
  for (std::size_t i = 0; i < now.submaps.size(); ++i) {
    const SubmapPose& p = now.submaps[i];
    if (i >= held->submaps.size()) {
      u.submaps.push_back(p);
      continue;
    }
    const SubmapPose& h = held->submaps[i];
    if (h.id != p.id) return fullUpdate(now);
    if (!samePose(h.T_world_submap, p.T_world_submap))
      u.moved.push_back(poseChange(p.id, h.T_world_submap, p.T_world_submap));
  }
  u.closures.assign(now.closures.begin() + static_cast<std::ptrdiff_t>(held->closures.size()), now.closures.end());
  return u;
}

Result<std::vector<SubmapPose>> applyGraphUpdate(GraphState& held, const GraphUpdate& update) {
  if (update.full) {
    held.version = update.version;
    held.stamp_ns = update.stamp_ns;
    held.submaps = update.submaps;
    held.closures = update.closures;
    return held.submaps;
  }
  const auto resynchronise = [&](const std::string& why) {
    return Error{"graph update from version " + std::to_string(update.base_version) + " to " +
                 std::to_string(update.version) + ": " + why + ": resynchronise (GetGraph)"};
  };
  if (update.base_version != held.version) {
    return resynchronise("it does not apply to version " + std::to_string(held.version));
  }
  // The held poses with the changes applied, then the new submaps after them.
  std::vector<SubmapPose> submaps = held.submaps;
  std::vector<SubmapPose> set;
  set.reserve(update.moved.size() + update.submaps.size());
  auto h = submaps.begin();
  for (const PoseChange& c : update.moved) {
    h = std::lower_bound(h, submaps.end(), c.id, [](const SubmapPose& p, std::uint32_t id) { return p.id < id; });
    if (h == submaps.end() || h->id != c.id) return resynchronise("submap " + std::to_string(c.id) + " is not held");
    auto& m = h->T_world_submap.matrix();
    for (int k = 0; k < 12; ++k) m(k / 4, k % 4) = std::bit_cast<double>(bitsOf(m(k / 4, k % 4)) ^ c.bits_xor[k]);
    if (Status st = checkPose(c.id, h->T_world_submap); !st) return st.error();
    set.push_back(*h);
  }
  for (const SubmapPose& p : update.submaps) {
    if (!submaps.empty() && p.id <= submaps.back().id) {
      return resynchronise("new submap " + std::to_string(p.id) + " is not after the held ones");
    }
    submaps.push_back(p);
    set.push_back(p);
  }
  if (submaps.size() != update.n_submaps) {
    return resynchronise("it gives " + std::to_string(submaps.size()) + " submaps, it says " +
                         std::to_string(update.n_submaps));
  }
  held.submaps = std::move(submaps);
  held.closures.insert(held.closures.end(), update.closures.begin(), update.closures.end());
  held.version = update.version;
  held.stamp_ns = update.stamp_ns;
  return set;  // ascending: the changes' ids are, and every new id is after them
}

void toProto(const GraphUpdate& update, v1::GraphUpdate& out) {
  out.set_version(update.version);
  out.set_base_version(update.base_version);
  out.set_full(update.full);
  out.set_n_submaps(update.n_submaps);
  out.set_stamp_ns(update.stamp_ns);
  out.mutable_submap_ids()->Reserve(static_cast<int>(update.submaps.size()));
  out.mutable_poses()->Reserve(static_cast<int>(12 * update.submaps.size()));
  out.mutable_pose_form()->Reserve(static_cast<int>(update.submaps.size()));
  for (const SubmapPose& p : update.submaps) {
    out.add_submap_ids(p.id);
    const auto& m = p.T_world_submap.matrix();
    const std::uint32_t form = poseForm(p.T_world_submap);
    out.add_pose_form(form);
    if (form != 0) {
      for (const double v : {m(0, 0), m(0, 1), m(1, 0), m(1, 1), m(0, 3), m(1, 3), m(2, 3)}) out.add_poses(v);
      continue;
    }
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) out.add_poses(m(r, c));
    }
  }
  std::string changes;
  for (const PoseChange& c : update.moved) {
    out.add_changed_ids(c.id);
    encodeChange(c, changes);
  }
  out.set_pose_changes(std::move(changes));
  for (const ClosurePair& c : update.closures) {
    out.add_closures(c.from);
    out.add_closures(c.to);
  }
}

Result<GraphUpdate> fromProto(const v1::GraphUpdate& in) {
  GraphUpdate u;
  u.version = in.version();
  u.base_version = in.base_version();
  u.full = in.full();
  u.n_submaps = in.n_submaps();
  u.stamp_ns = in.stamp_ns();
  if (in.pose_form_size() != in.submap_ids_size()) {
    return Error{"graph_update.pose_form has " + std::to_string(in.pose_form_size()) + " entries for " +
                 std::to_string(in.submap_ids_size()) + " submap ids"};
  }
  int doubles = 0;
  for (int i = 0; i < in.pose_form_size(); ++i) {
    if (in.pose_form(i) > 31 || (in.pose_form(i) != 0 && (in.pose_form(i) & 1) == 0)) {
      return Error{"graph_update.pose_form " + std::to_string(in.pose_form(i)) + " is not a pose form"};
    }
    doubles += in.pose_form(i) != 0 ? 7 : 12;
  }
  if (in.poses_size() != doubles) {
    return Error{"graph_update.poses holds " + std::to_string(in.poses_size()) + " doubles for " +
                 std::to_string(in.submap_ids_size()) + " submap ids (" + std::to_string(doubles) +
                 " expected: 12 each, 7 for a yaw-only pose)"};
  }
  if (in.closures_size() % 2 != 0) return Error{"graph_update.closures holds an odd number of submap ids"};
  u.submaps.resize(static_cast<std::size_t>(in.submap_ids_size()));
  int at = 0;
  for (int i = 0; i < in.submap_ids_size(); ++i) {
    SubmapPose& p = u.submaps[static_cast<std::size_t>(i)];
    p.id = in.submap_ids(i);
    if (i > 0 && p.id <= in.submap_ids(i - 1)) {
      return Error{"graph_update.submap_ids are not ascending at index " + std::to_string(i)};
    }
    auto& m = p.T_world_submap.matrix();
    m.setIdentity();
    const auto next = [&]() { return in.poses(at++); };
    if (const std::uint32_t form = in.pose_form(i); form != 0) {
      for (int k = 0; k < 4; ++k) m(kZeros[k][0], kZeros[k][1]) = (form & (2u << k)) != 0 ? -0.0 : 0.0;
      m(0, 0) = next();
      m(0, 1) = next();
      m(1, 0) = next();
      m(1, 1) = next();
      m(0, 3) = next();
      m(1, 3) = next();
      m(2, 3) = next();
    } else {
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c) m(r, c) = next();
      }
    }
    if (Status st = checkPose(p.id, p.T_world_submap); !st) return st.error();
  }
  if (u.full && in.changed_ids_size() != 0) return Error{"graph_update: a full update with pose changes"};
  std::size_t read = 0;
  for (int i = 0; i < in.changed_ids_size(); ++i) {
    if (i > 0 && in.changed_ids(i) <= in.changed_ids(i - 1)) {
      return Error{"graph_update.changed_ids are not ascending at index " + std::to_string(i)};
    }
    auto c = decodeChange(in.changed_ids(i), in.pose_changes(), read);
    if (!c) return c.error();
    u.moved.push_back(*c);
  }
  if (read != in.pose_changes().size()) {
    return Error{"graph_update.pose_changes holds " + std::to_string(in.pose_changes().size() - read) +
                 " bytes after the last change"};
  }
  u.closures.resize(static_cast<std::size_t>(in.closures_size() / 2));
  for (std::size_t i = 0; i < u.closures.size(); ++i) {
    u.closures[i] = {in.closures(static_cast<int>(2 * i)), in.closures(static_cast<int>(2 * i + 1))};
  }
  if (u.full && u.n_submaps != u.submaps.size()) {
    return Error{"graph_update: full update lists " + std::to_string(u.submaps.size()) + " submaps, n_submaps says " +
                 std::to_string(u.n_submaps)};
  }
  return u;
}

}  // namespace vog::api
