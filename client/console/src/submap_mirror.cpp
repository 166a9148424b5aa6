#include "vog/console/submap_mirror.hpp"

#include <string>

namespace vog::console {

Result<std::vector<api::SubmapPose>> SubmapMirror::applyGraph(const api::GraphUpdate& update) {
  return api::applyGraphUpdate(graph_, update);
}

std::vector<std::uint32_t> SubmapMirror::missingGrids() const {
  std::vector<std::uint32_t> out;
  for (const api::SubmapPose& p : graph_.submaps) {
    if (grids_.count(p.id) == 0) out.push_back(p.id);
  }
  return out;
}

Status SubmapMirror::addGrid(std::uint32_t id, std::shared_ptr<const map::LocalGrid> grid) {
  if (!grid || !grid->finalized()) return Error{"submap " + std::to_string(id) + ": no finalized grid"};
  if (!merged_) {
    auto m = map::MergedMap::create(grid->config());
    if (!m) return Error{"submap " + std::to_string(id) + ": " + m.error().message};
    merged_ = std::move(m).value();
  } else {
    const map::GridConfig& a = merged_->config();
    const map::GridConfig& b = grid->config();
    if (a.resolution_m != b.resolution_m || a.clamp_min != b.clamp_min || a.clamp_max != b.clamp_max ||
        a.occupancy_threshold != b.occupancy_threshold) {
      return Error{"submap " + std::to_string(id) + " has another grid configuration than the submaps before it"};
    }
  }
  grids_[id] = std::move(grid);
  return {};
}

Result<map::SyncStats> SubmapMirror::sync() {
  if (!merged_) return map::SyncStats{};
  std::vector<map::SubmapEntry> entries;
  entries.reserve(graph_.submaps.size());
  for (const api::SubmapPose& p : graph_.submaps) {
    const auto it = grids_.find(p.id);
    if (it == grids_.end()) continue;
    entries.push_back({p.id, it->second, p.T_world_submap, p.T_world_submap.inverse()});
  }
  map::MergeConfig exact;
  exact.remerge_translation_m = 0.0;
  exact.remerge_rotation_rad = 0.0;
  exact.max_moves_per_sync = 0;  // a mirror moves every submap at once
  exact.threads = 1;
  auto stats = merged_->sync(entries, exact);
  if (!stats) return stats.error();
  synced_version_ = graph_.version;
  synced_complete_ = entries.size() == graph_.submaps.size();
  return stats;
}

}  // namespace vog::console
