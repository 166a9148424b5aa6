#pragma once
// Survey recording: drive a waypoint list through a World in simulated time and record every
// stream (sonar ranges, intensity frames, DVL, IMU, depth, corrupted odometry) plus ground truth
// (trajectory, true pose of each scan) to a directory. Format: sim/README.md.

#include "vog/core/result.hpp"
#include "vog/geometry/sonar.hpp"
#include "vog/sim/lockstep.hpp"
#include "vog/sim/nav_model.hpp"
#include "vog/sim/sonar_model.hpp"
#include "vog/sim/vehicle.hpp"
#include "vog/sim/world.hpp"
#include "vog/sonar/sonar_frame.hpp"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace vog::sim {

// The lockstep simulation's settings plus the survey's own limits.
struct SurveyConfig : LockstepConfig {
  double max_duration_s = 3600.0;  // simulated time limit
  // A waypoint not reached within factor * (nominal leg time) + 30 s is skipped and reported.
  double waypoint_timeout_factor = 3.0;

  Status validate() const;
};

struct SurveySummary {
  std::size_t n_scans = 0;
  std::size_t n_frames = 0;
  double duration_s = 0.0;
  double path_length_m = 0.0;
  int waypoints_reached = 0;
  int waypoints_skipped = 0;
  std::uint64_t collisions_refused = 0;
};

// Writes meta.yaml, ground_truth.csv, odometry.csv, scans.csv, scan_poses.csv, frames.bin,
// dvl.csv, imu.csv, depth.csv, events.csv into out_dir (created if missing).
Result<SurveySummary> runSurvey(const World& world, const std::vector<Waypoint>& waypoints, const SurveyConfig& config,
                                const std::string& path_label, const std::filesystem::path& out_dir);

// Readers of the recorded sonar streams (for replay and tests).
struct RecordedScan {
  std::uint32_t scan_index = 0;
  geometry::RangeScan scan;
};
Result<std::vector<RecordedScan>> readScans(const std::filesystem::path& scans_csv);

struct RecordedFrame {
  std::uint32_t scan_index = 0;
  sonar::SonarFrame frame;
};
Result<std::vector<RecordedFrame>> readFrames(const std::filesystem::path& frames_bin);

}  // namespace vog::sim
