#pragma once
// SourceAlignment: a resumed mission's odometry and stamps brought into the frame and the clock of
// the mission as journaled.
//
// After a restart, a source whose odometry frame is new (the simulator) starts again at its own
// origin; the vehicle is taken to be where it was when the daemon stopped (the last waypoint sent,
// where its controller held it, or the newest submap's base). At the first odometry sample the new
// frame is aligned to the old one by the planar part (x, y, yaw) of that pose: depth, roll and
// pitch are measured, not integrated. A source whose frame persists (the vehicle's own navigation)
// continues as it is. A source whose clock restarted continues one second after the last mapped
// stamp. A new mission has nothing to align.
//
// Lifecycle: construct (new or resumed); firstSample() with the first odometry sample after
// launch; then align() every sample and scan. Not thread-safe: the caller serialises.

#include "vog/app/vehicle_source.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/slam/submap_builder.hpp"

#include <cstdint>
#include <optional>

namespace vog::app {

class SourceAlignment {
 public:
  // A new mission.
  SourceAlignment() = default;
  // A resumed mission: the vehicle at T_map_vehicle, the old odometry frame at T_map_oldodom in the
  // map, the newest mapped stamp last_stamp_ns.
  SourceAlignment(const geometry::Pose3& T_map_vehicle, const geometry::Pose3& T_map_oldodom,
                  std::int64_t last_stamp_ns)
      : resume_(Resume{T_map_vehicle, T_map_oldodom, last_stamp_ns}) {}

  // Fixes the alignment at the first sample after launch (later calls change nothing).
  void firstSample(const OdometrySample& sample, bool persistent_frame);

  OdometrySample align(OdometrySample sample) const;
  slam::ScanInput align(slam::ScanInput scan) const;
  // The new odometry frame in the old one (identity when nothing is aligned).
  geometry::Pose3 T_oldodom_newodom() const { return T_oldodom_newodom_.value_or(geometry::Pose3::Identity()); }
  std::int64_t stampOffsetNs() const { return stamp_offset_ns_; }

 private:
  struct Resume {
    geometry::Pose3 T_map_vehicle;
    geometry::Pose3 T_map_oldodom;
    std::int64_t last_stamp_ns = 0;
  };
  std::optional<Resume> resume_;  // until the first sample
  std::optional<geometry::Pose3> T_oldodom_newodom_;
  std::int64_t stamp_offset_ns_ = 0;
};

}  // namespace vog::app
