#pragma once
// WaypointFollower: the payload side of the backseat's go-to-position exchange. It hands the
// planner's waypoints to the vehicle one at a time as $BPGHP sentences (position, depth, speed and
// heading), resends each until the vehicle acknowledges it (AckTracker: 5 s, 3 tries), and moves on
// when the vehicle's own navigation ($BFNVG, $BFNVR) says it arrived: within the position and
// heading tolerances and slower than the arrival speed. An empty list holds the vehicle where its
// navigation says it is. A refused or unacknowledged command drops the rest of the list (the
// planner replans from where the vehicle is); `lastError()` says why. A waypoint not reached
// within twice the time the move takes at the speed and yaw-rate limits plus a margin (the vehicle
// stopped short: an obstacle, a controller that gave up) also drops the list, and is reported as an
// obstruction where the vehicle stopped. Without a backseat
// (`expect_acks` false) the same logic runs on the daemon's own odometry and nothing is sent.
//
// Frames: waypoints come in the daemon's odometry frame; the vehicle steers in its navigation
// frame. T_nav_odom (planar) is updated at every navigation fix from the odometry pose at the same
// stamp; a waypoint is converted when it is commanded.
//
// Pure: time, navigation and acknowledgements are arguments; poll() returns the sentences to write.
// Lifecycle: construct; setWaypoints() any time; onNavigation()/onAck() as they arrive; poll()
// periodically. Invariants: at most one command is outstanding; idle() is true only when every
// waypoint given was reached, dropped or none was given.

#include "vog/app/device_feed.hpp"
#include "vog/app/vehicle_source.hpp"
#include "vog/backseat/backseat.hpp"
#include "vog/backseat/local_tangent_plane.hpp"
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/geometry/sonar.hpp"

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace vog::app {

struct WaypointFollowerConfig {
  double arrival_tolerance_m = 0.15;
  double arrival_tolerance_rad = geometry::deg2rad(3.0);
  double arrival_max_speed_mps = 0.03;
  double speed_mps = 0.25;                 // thesis Table 4.2, v_max
  double yaw_rate_radps = 0.15;            // thesis Table 4.2, psi (for the arrival timeout)
  double arrival_timeout_margin_s = 10.0;  // added to twice the time the move takes
  // False without a backseat link (the waypoints reach the vehicle's controller some other way,
  // e.g. the API's waypoint stream): commands are not tracked and arrival is judged on the
  // navigation given, this daemon's own odometry.
  bool expect_acks = true;
  backseat::AckTrackerConfig ack;
  std::int64_t heartbeat_period_ns = 1'000'000'000;  // $BPSTS every second (PROTOCOLS.md)

  Status validate() const;
};

struct FollowerStats {
  std::uint64_t commands_sent = 0;  // first sends, not resends
  std::uint64_t resends = 0;
  std::uint64_t accepted = 0;
  std::uint64_t refused = 0;  // refused or never acknowledged
  std::uint64_t arrived = 0;
  std::uint64_t timeouts = 0;  // not reached in time
};

class WaypointFollower {
 public:
  WaypointFollower(const WaypointFollowerConfig& config, const backseat::LocalTangentPlane& ltp)
      : config_(config), ltp_(ltp), acks_(config.ack) {}

  // Replaces the list (odometry frame); empty = hold the current position.
  void setWaypoints(std::vector<SourceWaypoint> waypoints_odom);
  // A navigation fix of the vehicle, with this daemon's odometry pose at its stamp when it has one.
  void onNavigation(const VehicleNavigation& navigation, const std::optional<geometry::Pose3>& T_odom_vehicle);
  void onAck(const backseat::AckSentence& ack);
  // Sentences to write at `now_ns` (commands, resends, the heartbeat). `time` is the UTC time of
  // day the sentences carry; `heartbeat_text` the payload state for $BPSTS.
  std::vector<std::string> poll(std::int64_t now_ns, backseat::TimeOfDay time, int heartbeat_state,
                                const std::string& heartbeat_text);

  bool idle() const { return waypoints_.empty() && !hold_pending_; }
  const FollowerStats& stats() const { return stats_; }
  const std::string& lastError() const { return last_error_; }
  // The obstruction of the last timeout, once.
  std::optional<SourceObstruction> takeObstruction() { return std::exchange(obstruction_, std::nullopt); }

 private:
  std::optional<std::string> command(const SourceWaypoint& w_nav, std::int64_t now_ns, backseat::TimeOfDay time);
  bool arrived(const SourceWaypoint& w_nav) const;
  void dropAll(const std::string& why);

  WaypointFollowerConfig config_;
  backseat::LocalTangentPlane ltp_;
  backseat::AckTracker acks_;
  backseat::HeartbeatScheduler heartbeat_{config_.heartbeat_period_ns};
  std::deque<SourceWaypoint> waypoints_;  // odometry frame; front = next or current
  bool front_commanded_ = false;
  bool hold_pending_ = false;                    // an empty list arrived: command a hold once
  std::optional<SourceWaypoint> target_;         // navigation frame of the command in force
  std::int64_t deadline_ns_ = 0;                 // the front waypoint counts as not reached after this
  std::optional<std::uint32_t> outstanding_id_;  // sent, not yet acknowledged
  std::uint32_t next_id_ = 1;
  geometry::Pose3 T_nav_odom_ = geometry::Pose3::Identity();
  std::optional<VehicleNavigation> navigation_;  // newest
  FollowerStats stats_;
  std::string last_error_;
  std::optional<SourceObstruction> obstruction_;
};

}  // namespace vog::app
