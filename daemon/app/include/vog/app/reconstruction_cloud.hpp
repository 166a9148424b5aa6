#pragma once
// ReconstructionCloud: the reconstruction vogd serves (GetCloud): the centres of the merged map's
// occupied voxels with the map version they come from. The API (io thread) only takes the newest
// cloud built; the cloud is built on the daemon's main thread (update()), and only after someone
// asked: walking every known voxel never holds up the API. One lock, below; building is outside it.

#include "vog/api/domain.hpp"
#include "vog/map/merged_map.hpp"

#include <memory>
#include <mutex>

namespace vog::app {

class ReconstructionCloud {
 public:
  // The newest cloud built (null before the first); asks for one of the newest map. Any thread.
  std::shared_ptr<const api::ServedCloud> latest();
  // Builds the cloud of `snapshot` when one was asked for and the newest built is of an older map.
  // One thread (the builder).
  void update(const std::shared_ptr<const map::MergedMap>& snapshot);

 private:
  std::mutex mutex_;
  std::shared_ptr<const api::ServedCloud> cloud_;  // guarded by mutex_
  bool wanted_ = false;                            // guarded by mutex_: asked for since the last build
};

}  // namespace vog::app
