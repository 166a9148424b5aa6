#include "vog/app/reconstruction_cloud.hpp"

#include "vog/map/voxel_key.hpp"

namespace vog::app {

std::shared_ptr<const api::ServedCloud> ReconstructionCloud::latest() {
  const std::lock_guard lock(mutex_);
  wanted_ = true;
  return cloud_;
}

void ReconstructionCloud::update(const std::shared_ptr<const map::MergedMap>& snapshot) {
  if (!snapshot) return;
  {
    const std::lock_guard lock(mutex_);
    if (!wanted_ || (cloud_ && cloud_->map_version == snapshot->version())) return;
    wanted_ = false;
  }
  auto cloud = std::make_shared<api::ServedCloud>();
  cloud->map_version = snapshot->version();
  const double res = snapshot->resolution();
  snapshot->forEachKnown([&](const map::VoxelKey& key, const map::VoxelValue& value) {
    if (value.status != map::Occupancy::kOccupied) return;
    api::CloudPoint p;
    p.p_world_m = map::keyToCentre(key, res).cast<float>();
    cloud->points.push_back(p);
  });
  const std::lock_guard lock(mutex_);
  cloud_ = std::move(cloud);
}

}  // namespace vog::app
