#include "vog/slam/revisit_policy.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

namespace vog::slam {

std::vector<ClosurePair> closurePairs(const std::vector<LoopClosure>& closures) {
  std::vector<ClosurePair> out;
  out.reserve(closures.size());
  for (const LoopClosure& c : closures) out.push_back({c.from, c.to});
  return out;
}

Status RevisitConfig::validate() const {
  if (!(after_s >= 0.0) || !std::isfinite(after_s))
    return Error{"revisit config: after_s = " + std::to_string(after_s) + " must be finite and >= 0 (0 = off)"};
  if (!(anchor_span_s > 0.0) || !std::isfinite(anchor_span_s))
    return Error{"revisit config: anchor_span_s = " + std::to_string(anchor_span_s) + " must be finite and > 0"};
  return {};
}

Result<RevisitPolicy> RevisitPolicy::create(const RevisitConfig& config, std::int64_t start_stamp_ns) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  return RevisitPolicy(config, start_stamp_ns);
}

std::vector<geometry::Pose3> RevisitPolicy::due(const std::vector<SubmapRecord>& submaps,
                                                const std::vector<ClosurePair>& closures,
                                                const Eigen::Vector3d& p_world_now, std::int64_t now_ns) {
  auto startOf = [&](std::int64_t index) { return secondsOf(submaps[static_cast<std::size_t>(index)].first_stamp_ns); };
  auto known = [&](std::int64_t index) { return index >= 0 && static_cast<std::size_t>(index) < submaps.size(); };
  for (; closures_seen_ < closures.size(); ++closures_seen_) {
    const ClosurePair& c = closures[closures_seen_];
    if (!known(c.from) || !known(c.to)) continue;
    if (startOf(c.to) - startOf(c.from) >= config_.anchor_span_s)
      last_anchor_s_ = std::max(last_anchor_s_, startOf(c.to));
  }
  const double now_s = secondsOf(now_ns);
  if (config_.after_s <= 0.0 || !(now_s - std::max(last_anchor_s_, last_revisit_s_) > config_.after_s)) return {};
  std::vector<std::pair<double, geometry::Pose3>> views;
  for (const SubmapRecord& r : submaps) {
    if (secondsOf(r.first_stamp_ns) > now_s - config_.anchor_span_s) continue;
    views.emplace_back((r.T_world_base.translation() - p_world_now).norm(), r.T_world_base);
  }
  if (views.empty()) return {};
  std::stable_sort(views.begin(), views.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  last_revisit_s_ = now_s;
  ++revisits_;
  std::vector<geometry::Pose3> out;
  out.reserve(views.size());
  for (auto& v : views) out.push_back(v.second);
  return out;
}

}  // namespace vog::slam
