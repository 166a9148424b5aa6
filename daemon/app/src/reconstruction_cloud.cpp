#include "vog/app/reconstruction_cloud.hpp"

#include "vog/map/voxel_key.hpp"

namespace vog::app {

std::shared_ptr<const api::Cloud> ReconstructionCloud::of(const std::shared_ptr<const map::MergedMap>& snapshot) {
  if (!snapshot) return nullptr;
  {
    const std::lock_guard lock(mutex_);
    if (cloud_ && version_ == snapshot->version()) return cloud_;
  }
  auto cloud = std::make_shared<api::Cloud>();
  const double res = snapshot->resolution();
  snapshot->forEachKnown([&](const map::VoxelKey& key, const map::VoxelValue& value) {
    if (value.status != map::Occupancy::kOccupied) return;
    api::CloudPoint p;
    p.p_world_m = map::keyToCentre(key, res).cast<float>();
    cloud->push_back(p);
  });
  const std::lock_guard lock(mutex_);
  // Two clients may build the same version at once; the newer version is kept.
  if (!cloud_ || snapshot->version() >= version_) {
    cloud_ = std::move(cloud);
    version_ = snapshot->version();
    return cloud_;
  }
  return cloud;
}

}  // namespace vog::app
