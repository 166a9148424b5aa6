#include "vog/slam/revisit_policy.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace vog::slam {
namespace {

constexpr std::int64_t kStart = 1'700'000'000'000'000'000;  // an epoch stamp: the policy works relative to it
constexpr std::int64_t kSecond = 1'000'000'000;

// Submaps every 10 s, at x = index metres.
std::vector<SubmapRecord> submapsEvery10s(int n) {
  std::vector<SubmapRecord> out;
  for (int i = 0; i < n; ++i) {
    SubmapRecord r;
    r.index = i;
    r.first_stamp_ns = kStart + 10 * i * kSecond;
    r.T_world_base = geometry::poseFromXyzRpy(i, 0.0, -2.0, 0.0, 0.0, 0.1 * i);
    out.push_back(r);
  }
  return out;
}

ClosurePair closure(std::int64_t from, std::int64_t to) { return {from, to}; }

TEST(RevisitPolicy, DueAfterAStretchWithoutAnAnchoringClosureNearestOldViewFirst) {
  RevisitConfig config;
  config.after_s = 100.0;
  config.anchor_span_s = 50.0;
  RevisitPolicy policy = RevisitPolicy::create(config, kStart).value();
  const auto submaps = submapsEvery10s(12);  // the last one started at 110 s
  const Eigen::Vector3d here(4.2, 0.0, -2.0);
  // 99 s after the start: not yet.
  EXPECT_TRUE(policy.due(submaps, {}, here, kStart + 99 * kSecond).empty());
  // 111 s: due. Views: submaps started at least 50 s before (0..6), nearest to x = 4.2 first.
  const auto views = policy.due(submaps, {}, here, kStart + 111 * kSecond);
  ASSERT_EQ(views.size(), 7u);
  const std::vector<int> order{4, 5, 3, 6, 2, 1, 0};
  for (std::size_t k = 0; k < order.size(); ++k)
    EXPECT_TRUE(views[k].isApprox(submaps[static_cast<std::size_t>(order[k])].T_world_base)) << k;
  EXPECT_EQ(policy.revisits(), 1);
  // The revisit counts like an anchor: the next is due after_s later, not at once.
  EXPECT_TRUE(policy.due(submaps, {}, here, kStart + 210 * kSecond).empty());
  EXPECT_FALSE(policy.due(submaps, {}, here, kStart + 212 * kSecond).empty());
  EXPECT_EQ(policy.revisits(), 2);
}

TEST(RevisitPolicy, OnlyClosuresSpanningTheAnchorSpanPostponeIt) {
  RevisitConfig config;
  config.after_s = 100.0;
  config.anchor_span_s = 50.0;
  const auto submaps = submapsEvery10s(12);
  const Eigen::Vector3d here(0.0, 0.0, -2.0);
  {
    // 8 -> 11 started 30 s apart: not anchoring; still due at 110 s.
    RevisitPolicy policy = RevisitPolicy::create(config, kStart).value();
    EXPECT_FALSE(policy.due(submaps, {closure(8, 11)}, here, kStart + 110 * kSecond).empty());
  }
  {
    // 2 -> 9 started 70 s apart: anchors at submap 9's start (90 s); due only after 190 s. A closure
    // naming an unknown submap is ignored.
    RevisitPolicy policy = RevisitPolicy::create(config, kStart).value();
    const std::vector<ClosurePair> closures{closure(2, 9), closure(3, 40)};
    EXPECT_TRUE(policy.due(submaps, closures, here, kStart + 110 * kSecond).empty());
    EXPECT_TRUE(policy.due(submaps, closures, here, kStart + 189 * kSecond).empty());
    EXPECT_FALSE(policy.due(submaps, closures, here, kStart + 191 * kSecond).empty());
  }
}

TEST(RevisitPolicy, OffOrNothingOldEnoughIsNeverDueAndBadConfigIsNamed) {
  RevisitConfig off;
  off.after_s = 0.0;
  RevisitPolicy never = RevisitPolicy::create(off, kStart).value();
  EXPECT_TRUE(never.due(submapsEvery10s(50), {}, Eigen::Vector3d::Zero(), kStart + 10'000 * kSecond).empty());
  EXPECT_EQ(never.revisits(), 0);

  RevisitConfig config;
  config.after_s = 10.0;
  config.anchor_span_s = 500.0;  // no submap is that old yet
  RevisitPolicy young = RevisitPolicy::create(config, kStart).value();
  EXPECT_TRUE(young.due(submapsEvery10s(5), {}, Eigen::Vector3d::Zero(), kStart + 60 * kSecond).empty());
  EXPECT_EQ(young.revisits(), 0);

  RevisitConfig bad;
  bad.after_s = -1.0;
  auto r = RevisitPolicy::create(bad, kStart);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("after_s"), std::string::npos);
  bad = RevisitConfig{};
  bad.anchor_span_s = std::numeric_limits<double>::quiet_NaN();
  r = RevisitPolicy::create(bad, kStart);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("anchor_span_s"), std::string::npos);
}

}  // namespace
}  // namespace vog::slam
