// The graph stream's updates without sockets: an update carries exactly the new and moved base poses
// (the moved as changes against the held ones) and the new closures, applying it reproduces the newer
// graph bit for bit, and what arrives over the wire is checked.
#include "vog/api/graph.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

namespace vog::api {
namespace {

GraphState chain(std::uint64_t version, int n) {
  GraphState g;
  g.version = version;
  for (int i = 0; i < n; ++i) {
    g.submaps.push_back(
        {static_cast<std::uint32_t>(i), geometry::poseFromXyzRpy(1.3 * i, 0.2 * i, -2.0, 0.01, -0.02, 0.1 * i)});
  }
  return g;
}

bool bitEqual(const GraphState& a, const GraphState& b) {
  if (a.version != b.version || a.submaps.size() != b.submaps.size() || a.closures != b.closures) return false;
  for (std::size_t i = 0; i < a.submaps.size(); ++i) {
    if (a.submaps[i].id != b.submaps[i].id ||
        std::memcmp(a.submaps[i].T_world_submap.matrix().data(), b.submaps[i].T_world_submap.matrix().data(),
                    16 * sizeof(double)) != 0) {
      return false;
    }
  }
  return true;
}

// Through protobuf and back, as a client receives it.
GraphUpdate wire(const GraphUpdate& u) {
  v1::GraphUpdate p;
  toProto(u, p);
  v1::GraphUpdate parsed;
  EXPECT_TRUE(parsed.ParseFromString(p.SerializeAsString()));
  return fromProto(parsed).value();
}

TEST(GraphUpdate, CarriesOnlyNewAndMovedPosesAndReproducesTheGraphBitForBit) {
  const GraphState v1 = chain(1, 5);
  GraphState v2 = chain(2, 7);  // two new submaps; a loop closure moved submaps 3 and 4
  v2.submaps[3].T_world_submap = geometry::poseFromXyzRpy(0.1, 0.2, 0.3, 0.0, 0.0, 0.4) * v2.submaps[3].T_world_submap;
  v2.submaps[4].T_world_submap.translation().x() += 1e-12;  // a move in the last bits still travels
  v2.closures = {{6, 1}};

  const GraphUpdate u = graphUpdate(&v1, v2);
  EXPECT_FALSE(u.full);
  EXPECT_EQ(u.base_version, 1u);
  ASSERT_EQ(u.moved.size(), 2u);
  EXPECT_EQ(u.moved[0].id, 3u);
  EXPECT_EQ(u.moved[1].id, 4u);
  ASSERT_EQ(u.submaps.size(), 2u);
  EXPECT_EQ(u.submaps[0].id, 5u);
  EXPECT_EQ(u.submaps[1].id, 6u);
  ASSERT_EQ(u.closures.size(), 1u);

  GraphState held = v1;
  const auto set = applyGraphUpdate(held, wire(u));
  ASSERT_TRUE(set.ok()) << set.error().message;
  EXPECT_TRUE(bitEqual(held, v2));
  ASSERT_EQ(set->size(), 4u) << "the poses it set: 3 and 4 moved, 5 and 6 new";
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ((*set)[i].id, 3u + i);
    EXPECT_TRUE((*set)[i].T_world_submap.matrix() == v2.submaps[3 + i].T_world_submap.matrix());
  }

  // From nothing: a full update.
  const GraphUpdate f = graphUpdate(nullptr, v2);
  EXPECT_TRUE(f.full);
  GraphState fresh;
  ASSERT_TRUE(applyGraphUpdate(fresh, wire(f)).ok());
  EXPECT_TRUE(bitEqual(fresh, v2));

  // Unchanged: nothing but the version.
  GraphState v3 = v2;
  v3.version = 3;
  EXPECT_TRUE(graphUpdate(&v2, v3).submaps.empty());
  EXPECT_TRUE(graphUpdate(&v2, v3).moved.empty());
  EXPECT_TRUE(graphUpdate(&v2, v3).closures.empty());
}

// Moved poses travel as the XOR of their bits with the held ones: any change (signed zeros, subnormals,
// infinities' neighbours, a flipped sign, moves of every size) comes back bit for bit, and a loop
// closure's small moves cost well under 100 bytes a submap.
TEST(GraphUpdate, MovedPosesTravelAsChangesAndComeBackBitForBit) {
  std::mt19937_64 rng(17);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (const double scale : {1e-12, 1e-6, 1e-3, 0.05, 1.0, 100.0}) {
    GraphState before;
    before.version = 10;
    for (std::uint32_t i = 0; i < 40; ++i) {
      before.submaps.push_back({i, geometry::poseFromXyzRpy(20 * noise(rng), 20 * noise(rng), -3 + noise(rng),
                                                            0.02 * noise(rng), 0.02 * noise(rng), 3 * noise(rng))});
    }
    GraphState after = before;
    after.version = 11;
    for (SubmapPose& p : after.submaps) {
      p.T_world_submap =
          geometry::poseFromXyzRpy(scale * noise(rng), scale * noise(rng), scale * noise(rng), 0.1 * scale * noise(rng),
                                   0.1 * scale * noise(rng), 0.1 * scale * noise(rng)) *
          p.T_world_submap;
    }
    // A sign-only change of a zero and a change to the smallest subnormal.
    before.submaps[5].T_world_submap = geometry::poseFromXyzRpy(1.0, 2.0, -3.0, 0.0, 0.0, 0.7);
    before.submaps[5].T_world_submap.matrix()(0, 2) = 0.0;
    before.submaps[5].T_world_submap.matrix()(1, 2) = 0.0;
    after.submaps[5] = before.submaps[5];
    after.submaps[5].T_world_submap.matrix()(0, 2) = -0.0;
    after.submaps[5].T_world_submap.matrix()(1, 2) = std::numeric_limits<double>::denorm_min();
    after.submaps[6] = before.submaps[6];  // unmoved: not sent
    const GraphUpdate u = graphUpdate(&before, after);
    EXPECT_EQ(u.moved.size(), 39u);
    EXPECT_TRUE(u.submaps.empty());
    v1::Envelope e;
    toProto(u, *e.mutable_graph_update());
    const double per_submap = static_cast<double>(e.ByteSizeLong() + 4) / 39.0;
    if (scale <= 0.05) {
      EXPECT_LT(per_submap, 90.0) << "scale " << scale;
    }
    GraphState held = before;
    const auto set = applyGraphUpdate(held, wire(u));
    ASSERT_TRUE(set.ok()) << set.error().message;
    EXPECT_TRUE(bitEqual(held, after)) << "scale " << scale;
    EXPECT_EQ(set->size(), 39u);
  }
}

// A change is applied to what the client holds: one for a submap it does not hold, or one that makes a
// pose that is no rotation, is refused and leaves the graph as it was.
TEST(GraphUpdate, AChangeThatDoesNotFitTheHeldGraphIsRefused) {
  const GraphState v1 = chain(1, 4);
  GraphState v2 = chain(2, 4);
  v2.submaps[2].T_world_submap.translation().y() += 0.25;
  GraphUpdate u = graphUpdate(&v1, v2);
  ASSERT_EQ(u.moved.size(), 1u);

  GraphState held = v1;
  held.submaps.erase(held.submaps.begin() + 2);  // a client that lacks submap 2 at this version
  held.submaps.push_back({9, geometry::Pose3::Identity()});
  auto st = applyGraphUpdate(held, wire(u));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("submap 2 is not held"), std::string::npos) << st.error().message;

  held = v1;
  u.moved[0].bits_xor[0] ^= std::uint64_t{1} << 62;  // r00's exponent flipped: no rotation any more
  st = applyGraphUpdate(held, wire(u));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("no rotation"), std::string::npos) << st.error().message;
  EXPECT_TRUE(bitEqual(held, v1)) << "unchanged";
}

TEST(GraphUpdate, YawOnlyPosesTravelAsSevenDoublesAndComeBackBitForBit) {
  GraphState planar;
  planar.version = 4;
  for (int i = 0; i < 50; ++i) {
    planar.submaps.push_back(
        {static_cast<std::uint32_t>(i), geometry::poseFromXyzRpy(0.37 * i, -1.1 * i, -2.5, 0.0, 0.0, 0.13 * i - 3.0)});
  }
  planar.submaps[7].T_world_submap = geometry::poseFromXyzRpy(1, 2, 3, 0.001, 0.0, 0.5);  // tilted: 12 doubles
  v1::GraphUpdate p;
  toProto(graphUpdate(nullptr, planar), p);
  EXPECT_EQ(p.poses_size(), 49 * 7 + 12);
  GraphState back;
  ASSERT_TRUE(applyGraphUpdate(back, fromProto(p).value()).ok());
  EXPECT_TRUE(bitEqual(back, planar));
  // What a loop closure moving every planar submap costs per submap on the wire.
  v1::Envelope e;
  *e.mutable_graph_update() = p;
  EXPECT_LT(static_cast<double>(e.ByteSizeLong() + 4) / 50.0, 70.0);
}

TEST(GraphUpdate, AnUpdateForAnotherVersionIsRefusedAndAShrunkGraphIsSentWhole) {
  const GraphState v1 = chain(1, 5);
  const GraphState v2 = chain(2, 6);
  const GraphState v3 = chain(3, 7);
  GraphState held = v1;
  const auto st = applyGraphUpdate(held, graphUpdate(&v2, v3));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("resynchronise"), std::string::npos) << st.error().message;
  EXPECT_TRUE(bitEqual(held, v1)) << "unchanged";

  // A closure switched off (the list is not the held one grown) or a submap gone: full updates.
  GraphState with = v2;
  with.closures = {{5, 0}, {4, 1}};
  GraphState without = v3;
  without.closures = {{4, 1}};
  EXPECT_TRUE(graphUpdate(&with, without).full);
  EXPECT_TRUE(graphUpdate(&v3, v2).full);
  held = with;
  ASSERT_TRUE(applyGraphUpdate(held, wire(graphUpdate(&with, without))).ok());
  EXPECT_TRUE(bitEqual(held, without));
}

TEST(GraphUpdate, WhatArrivesIsChecked) {
  v1::GraphUpdate p;
  toProto(graphUpdate(nullptr, chain(1, 3)), p);
  ASSERT_TRUE(fromProto(p).ok());

  v1::GraphUpdate short_poses = p;
  short_poses.mutable_poses()->RemoveLast();
  EXPECT_NE(fromProto(short_poses).error().message.find("12 each"), std::string::npos);

  v1::GraphUpdate nan = p;
  nan.set_poses(3, std::nan(""));
  EXPECT_NE(fromProto(nan).error().message.find("not finite"), std::string::npos);

  v1::GraphUpdate skewed = p;
  skewed.set_poses(0, 2.0);  // r00 = 2: no rotation
  EXPECT_NE(fromProto(skewed).error().message.find("no rotation"), std::string::npos);

  v1::GraphUpdate unordered = p;
  unordered.set_submap_ids(1, 0);
  EXPECT_NE(fromProto(unordered).error().message.find("ascending"), std::string::npos);

  v1::GraphUpdate odd = p;
  odd.add_closures(1);
  EXPECT_NE(fromProto(odd).error().message.find("odd"), std::string::npos);

  v1::GraphUpdate flags = p;
  flags.mutable_pose_form()->RemoveLast();
  EXPECT_NE(fromProto(flags).error().message.find("pose_form"), std::string::npos);
  v1::GraphUpdate form = p;
  form.set_pose_form(0, 6);
  EXPECT_NE(fromProto(form).error().message.find("not a pose form"), std::string::npos);

  v1::GraphUpdate count = p;
  count.set_n_submaps(4);
  EXPECT_NE(fromProto(count).error().message.find("n_submaps"), std::string::npos);

  // Changes: the ids ascending, each with its 6-byte header and the bytes it announces, nothing after.
  GraphState moved = chain(2, 3);
  moved.submaps[0].T_world_submap.translation().x() += 0.5;
  moved.submaps[2].T_world_submap.translation().z() -= 0.5;
  v1::GraphUpdate c;
  const GraphState base = chain(1, 3);
  toProto(graphUpdate(&base, moved), c);
  ASSERT_EQ(c.changed_ids_size(), 2);
  ASSERT_TRUE(fromProto(c).ok());
  v1::GraphUpdate truncated = c;
  truncated.mutable_pose_changes()->pop_back();
  EXPECT_NE(fromProto(truncated).error().message.find("ends inside submap 2"), std::string::npos);
  v1::GraphUpdate trailing = c;
  trailing.mutable_pose_changes()->push_back('x');
  EXPECT_NE(fromProto(trailing).error().message.find("after the last change"), std::string::npos);
  v1::GraphUpdate nibble = c;
  (*nibble.mutable_pose_changes())[0] = static_cast<char>(0x09);
  EXPECT_NE(fromProto(nibble).error().message.find("leading zero bytes"), std::string::npos);
  v1::GraphUpdate backwards = c;
  backwards.set_changed_ids(1, 0);
  EXPECT_NE(fromProto(backwards).error().message.find("changed_ids are not ascending"), std::string::npos);
  v1::GraphUpdate full_with_changes = c;
  full_with_changes.set_full(true);
  EXPECT_NE(fromProto(full_with_changes).error().message.find("full update with pose changes"), std::string::npos);
}

}  // namespace
}  // namespace vog::api
