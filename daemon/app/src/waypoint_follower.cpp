#include "vog/app/waypoint_follower.hpp"

#include <cmath>
#include <numbers>
#include <sstream>

namespace vog::app {
namespace {

geometry::Pose3 poseOf(const SourceWaypoint& w) {
  return geometry::poseFromXyzRpy(w.p_odom_m.x(), w.p_odom_m.y(), w.p_odom_m.z(), 0.0, 0.0, w.yaw_rad);
}

// True heading (degrees, clockwise from north, [0, 360)) of a world yaw (counter-clockwise from east).
double headingDegOf(double yaw_rad) {
  double h = std::fmod(90.0 - yaw_rad * 180.0 / std::numbers::pi, 360.0);
  if (h < 0.0) h += 360.0;
  return h >= 360.0 ? 0.0 : h;
}

}  // namespace

Status WaypointFollowerConfig::validate() const {
  auto bad = [](const char* key, double v, const char* range) {
    return Error{std::string("devices.backseat.") + key + ": " + std::to_string(v) + " is outside " + range};
  };
  if (!(arrival_tolerance_m > 0.0 && arrival_tolerance_m <= 10.0))
    return bad("arrival_tolerance_m", arrival_tolerance_m, "(0, 10]");
  if (!(arrival_tolerance_rad > 0.0 && arrival_tolerance_rad <= std::numbers::pi))
    return bad("arrival_tolerance_deg", arrival_tolerance_rad * 180.0 / std::numbers::pi, "(0, 180]");
  if (!(arrival_max_speed_mps > 0.0 && arrival_max_speed_mps <= 10.0))
    return bad("arrival_max_speed_mps", arrival_max_speed_mps, "(0, 10]");
  if (!(speed_mps > 0.0 && speed_mps <= 10.0)) return bad("speed_mps", speed_mps, "(0, 10]");
  if (!(yaw_rate_radps > 0.0 && yaw_rate_radps <= 10.0)) return bad("yaw_rate_radps", yaw_rate_radps, "(0, 10]");
  if (!(arrival_timeout_margin_s >= 0.0 && arrival_timeout_margin_s <= 3600.0))
    return bad("arrival_timeout_margin_s", arrival_timeout_margin_s, "[0, 3600]");
  if (heartbeat_period_ns <= 0) return Error{"devices.backseat: the heartbeat period must be positive"};
  return ack.validate();
}

void WaypointFollower::setWaypoints(std::vector<SourceWaypoint> waypoints_odom) {
  waypoints_.assign(waypoints_odom.begin(), waypoints_odom.end());
  front_commanded_ = false;
  hold_pending_ = waypoints_.empty();
}

void WaypointFollower::onNavigation(const VehicleNavigation& navigation,
                                    const std::optional<geometry::Pose3>& T_odom_vehicle) {
  navigation_ = navigation;
  if (T_odom_vehicle) {
    T_nav_odom_ = geometry::planarPart(navigation.T_world_vehicle) * geometry::planarPart(*T_odom_vehicle).inverse();
  }
}

void WaypointFollower::onAck(const backseat::AckSentence& ack) {
  (void)acks_.onAck(ack);  // an acknowledgement of nothing pending (a late duplicate) changes nothing
}

std::optional<std::string> WaypointFollower::command(const SourceWaypoint& w_nav, std::int64_t now_ns,
                                                     backseat::TimeOfDay time) {
  backseat::WaypointCommand c;
  c.time = time;
  c.id = next_id_++;
  const backseat::GeoPoint g = ltp_.toGeo(w_nav.p_odom_m.head<2>());
  c.latitude_deg = g.latitude_deg;
  c.longitude_deg = g.longitude_deg;
  c.depth_m = -w_nav.p_odom_m.z();
  c.speed_mps = config_.speed_mps;
  c.heading_deg = headingDegOf(w_nav.yaw_rad);
  ++stats_.commands_sent;
  target_ = w_nav;
  // Twice the move at the limits (from where the vehicle is now), plus the margin.
  double move_s = 0.0;
  if (navigation_) {
    const geometry::Pose3& T = navigation_->T_world_vehicle;
    move_s = (w_nav.p_odom_m - T.translation()).norm() / config_.speed_mps +
             std::abs(geometry::wrapAngle(w_nav.yaw_rad - geometry::yawOf(T.linear()))) / config_.yaw_rate_radps;
  }
  deadline_ns_ = now_ns + static_cast<std::int64_t>((2.0 * move_s + config_.arrival_timeout_margin_s) * 1e9);
  if (!config_.expect_acks) return backseat::encodeBackseat(c);
  auto sentence = acks_.send(c, now_ns);
  if (!sentence) {
    dropAll(sentence.error().message);
    return std::nullopt;
  }
  outstanding_id_ = c.id;
  return *sentence;
}

bool WaypointFollower::arrived(const SourceWaypoint& w_nav) const {
  if (!navigation_) return false;
  const geometry::Pose3& T = navigation_->T_world_vehicle;
  return (T.translation() - w_nav.p_odom_m).norm() <= config_.arrival_tolerance_m &&
         std::abs(geometry::wrapAngle(geometry::yawOf(T.linear()) - w_nav.yaw_rad)) <= config_.arrival_tolerance_rad &&
         navigation_->velocity_world_mps.norm() <= config_.arrival_max_speed_mps;
}

void WaypointFollower::dropAll(const std::string& why) {
  last_error_ = why;
  waypoints_.clear();
  front_commanded_ = false;
}

std::vector<std::string> WaypointFollower::poll(std::int64_t now_ns, backseat::TimeOfDay time, int heartbeat_state,
                                                const std::string& heartbeat_text) {
  std::vector<std::string> out = acks_.poll(now_ns);
  stats_.resends += out.size();
  for (const backseat::AckTracker::Outcome& o : acks_.takeOutcomes()) {
    if (outstanding_id_ != o.command_id) continue;
    outstanding_id_.reset();
    if (o.accepted) {
      ++stats_.accepted;
    } else {
      ++stats_.refused;
      target_.reset();
      dropAll("waypoint " + std::to_string(o.command_id) + " refused: " + o.reason);
    }
  }
  if (hold_pending_ && navigation_) {
    // Hold: the vehicle's own position and heading become its target.
    const geometry::Pose3& T = navigation_->T_world_vehicle;
    if (auto s = command({T.translation(), geometry::yawOf(T.linear())}, now_ns, time)) out.push_back(std::move(*s));
    hold_pending_ = false;
  }
  while (!waypoints_.empty() && !outstanding_id_) {
    if (!front_commanded_) {
      const geometry::Pose3 T_nav = T_nav_odom_ * poseOf(waypoints_.front());
      const std::optional<std::string> s =
          command({T_nav.translation(), geometry::yawOf(T_nav.linear())}, now_ns, time);
      if (!s) break;
      out.push_back(*s);
      front_commanded_ = true;
      break;
    }
    if (!target_) break;
    if (!arrived(*target_)) {
      if (now_ns > deadline_ns_ && navigation_) {
        ++stats_.timeouts;
        const geometry::Pose3 T_odom_nav = T_nav_odom_.inverse();
        obstruction_ =
            SourceObstruction{T_odom_nav * navigation_->T_world_vehicle.translation(), T_odom_nav * target_->p_odom_m};
        const Eigen::Vector3d p = navigation_->T_world_vehicle.translation();
        std::ostringstream why;
        why.setf(std::ios::fixed);
        why.precision(2);
        why << "waypoint not reached in time: the vehicle stopped at (" << p.x() << ", " << p.y() << ", " << p.z()
            << "), " << (target_->p_odom_m - p).norm() << " m short";
        target_.reset();
        dropAll(why.str());
      }
      break;
    }
    ++stats_.arrived;
    waypoints_.pop_front();
    front_commanded_ = false;
  }
  if (heartbeat_.due(now_ns)) out.push_back(heartbeat_.emit({time, heartbeat_state, heartbeat_text}, now_ns));
  return out;
}

}  // namespace vog::app
