#pragma once
// ReconstructionCloud: the reconstruction vogd serves (GetCloud): the centres of the merged map's
// occupied voxels, built once per map version and shared by every client that asks for that
// version. Thread-safe (one lock, below); the cloud is built outside it.

#include "vog/api/domain.hpp"
#include "vog/map/merged_map.hpp"

#include <cstdint>
#include <memory>
#include <mutex>

namespace vog::app {

class ReconstructionCloud {
 public:
  // The cloud of `snapshot` (nullptr for none).
  std::shared_ptr<const api::Cloud> of(const std::shared_ptr<const map::MergedMap>& snapshot);

 private:
  std::mutex mutex_;
  std::shared_ptr<const api::Cloud> cloud_;  // guarded by mutex_
  std::uint64_t version_ = 0;                // guarded by mutex_: the map version cloud_ was built from
};

}  // namespace vog::app
