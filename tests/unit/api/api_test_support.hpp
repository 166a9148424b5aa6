#pragma once
// What the API tests share: the operator secret their servers are configured with, and the check that
// a MapMirror equals the MergedMap it follows.

#include "vog/api/map_delta.hpp"
#include "vog/map/merged_map.hpp"

#include <gtest/gtest.h>

#include <cstddef>

namespace vog::api::test {

inline constexpr const char* kOperatorSecret = "operator-secret-0123456789";

// Every known voxel of `merged` has the same status and (float32, as map.proto carries it) log-odds
// in `mirror`, and both have the same blocks, version and resolution.
inline void expectMirrorEquals(const MapMirror& mirror, const map::MergedMap& merged) {
  std::size_t n = 0;
  merged.forEachKnown([&](const map::VoxelKey& k, const map::VoxelValue& v) {
    const map::VoxelValue m = mirror.at(k);
    ASSERT_EQ(m.status, v.status) << k.transpose();
    ASSERT_EQ(static_cast<float>(m.log_odds), static_cast<float>(v.log_odds)) << k.transpose();
    ++n;
  });
  EXPECT_GT(n, 1000u);
  EXPECT_EQ(mirror.blockCount(), merged.blockCount());
  EXPECT_EQ(mirror.version(), merged.version());
  EXPECT_EQ(mirror.resolution(), merged.resolution());
}

}  // namespace vog::api::test
