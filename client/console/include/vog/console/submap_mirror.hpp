#pragma once
// The VOG-Map topside: the closed submaps' grids by id (each fetched once: a closed submap never
// changes), the pose graph from vogd's graph stream, and their merge with vogd's own MergedMap at the
// graph's poses with re-merge tolerance 0. So at one graph version, with every grid held, the merged map
// holds the same sums and counts as vogd's merged map of its closed submaps at those poses.
//
// Thread: one owner (the console's link thread); not thread-safe.

#include "vog/api/graph.hpp"
#include "vog/map/merged_map.hpp"

#include <cstdint>
#include <map>
#include <memory>
#include <vector>

namespace vog::console {

class SubmapMirror {
 public:
  // A graph update; returns the poses it set (api::applyGraphUpdate). An error (the update does not
  // follow the held version) leaves the graph as it was: resynchronise with a full one (GetGraph).
  Result<std::vector<api::SubmapPose>> applyGraph(const api::GraphUpdate& update);
  const api::GraphState& graph() const { return graph_; }

  // The submaps of the graph whose grids are not held yet, ascending.
  std::vector<std::uint32_t> missingGrids() const;
  // Adopts a fetched grid. Every grid must share the first one's grid configuration.
  Status addGrid(std::uint32_t id, std::shared_ptr<const map::LocalGrid> grid);
  std::size_t gridCount() const { return grids_.size(); }

  // Merges the graph's submaps that have grids at the graph's poses (new ones in, moved ones re-merged,
  // vanished ones out). Null merged map until the first grid.
  Result<map::SyncStats> sync();
  const map::MergedMap* merged() const { return merged_.get(); }
  // An immutable snapshot for other threads (null before the first grid).
  std::shared_ptr<const map::MergedMap> snapshot() { return merged_ ? merged_->snapshot() : nullptr; }
  // The graph version the merged map was last synced at, and whether every submap was in it then.
  std::uint64_t syncedVersion() const { return synced_version_; }
  bool syncedComplete() const { return synced_complete_; }

 private:
  api::GraphState graph_;
  std::map<std::uint32_t, std::shared_ptr<const map::LocalGrid>> grids_;
  std::unique_ptr<map::MergedMap> merged_;
  std::uint64_t synced_version_ = 0;
  bool synced_complete_ = false;
};

}  // namespace vog::console
