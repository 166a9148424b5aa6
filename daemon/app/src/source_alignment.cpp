#include "vog/app/source_alignment.hpp"

namespace vog::app {

void SourceAlignment::firstSample(const OdometrySample& sample, bool persistent_frame) {
  if (!resume_) return;
  if (!persistent_frame) {
    const geometry::Pose3 T_oldodom_vehicle = resume_->T_map_oldodom.inverse() * resume_->T_map_vehicle;
    T_oldodom_newodom_ =
        geometry::planarPart(T_oldodom_vehicle) * geometry::planarPart(sample.T_odom_vehicle).inverse();
  }
  if (sample.stamp_ns <= resume_->last_stamp_ns)
    stamp_offset_ns_ = resume_->last_stamp_ns - sample.stamp_ns + 1'000'000'000;
  resume_.reset();
}

OdometrySample SourceAlignment::align(OdometrySample sample) const {
  sample.stamp_ns += stamp_offset_ns_;
  if (T_oldodom_newodom_) sample.T_odom_vehicle = *T_oldodom_newodom_ * sample.T_odom_vehicle;
  return sample;
}

slam::ScanInput SourceAlignment::align(slam::ScanInput scan) const {
  scan.scan.stamp_ns += stamp_offset_ns_;
  if (T_oldodom_newodom_) scan.T_world_vehicle_odom = *T_oldodom_newodom_ * scan.T_world_vehicle_odom;
  return scan;
}

}  // namespace vog::app
