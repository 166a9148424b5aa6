#include "vog/api/graph.hpp"

#include <Eigen/LU>

#include <algorithm>
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
    if (i < held->submaps.size()) {
      if (held->submaps[i].id != p.id) return fullUpdate(now);
      if (samePose(held->submaps[i].T_world_submap, p.T_world_submap)) continue;
    }
    u.submaps.push_back(p);
  }
  u.closures.assign(now.closures.begin() + static_cast<std::ptrdiff_t>(held->closures.size()), now.closures.end());
  return u;
}

Status applyGraphUpdate(GraphState& held, const GraphUpdate& update) {
  if (update.full) {
    held.version = update.version;
    held.stamp_ns = update.stamp_ns;
    held.submaps = update.submaps;
    held.closures = update.closures;
    return {};
  }
  if (update.base_version != held.version) {
    return Error{"graph update from version " + std::to_string(update.base_version) + " does not apply to version " +
                 std::to_string(held.version) + ": resynchronise (GetGraph)"};
  }
  std::vector<SubmapPose> merged;
  merged.reserve(std::max<std::size_t>(held.submaps.size(), update.n_submaps));
  auto h = held.submaps.begin();
  auto n = update.submaps.begin();
  while (h != held.submaps.end() || n != update.submaps.end()) {
    if (n == update.submaps.end() || (h != held.submaps.end() && h->id < n->id)) {
      merged.push_back(*h++);
    } else {
      if (h != held.submaps.end() && h->id == n->id) ++h;
      merged.push_back(*n++);
    }
  }
  if (merged.size() != update.n_submaps) {
    return Error{"graph update to version " + std::to_string(update.version) + " gives " +
                 std::to_string(merged.size()) + " submaps, it says " + std::to_string(update.n_submaps) +
                 ": resynchronise (GetGraph)"};
  }
  held.submaps = std::move(merged);
  held.closures.insert(held.closures.end(), update.closures.begin(), update.closures.end());
  held.version = update.version;
  held.stamp_ns = update.stamp_ns;
  return {};
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
    if (!m.allFinite()) return Error{"graph_update: submap " + std::to_string(p.id) + "'s pose is not finite"};
    const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
    if ((R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || R.determinant() < 0.0) {
      return Error{"graph_update: submap " + std::to_string(p.id) + "'s pose has no rotation matrix"};
    }
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
