#include "vog/api/convert.hpp"

#include <Eigen/Geometry>

#include <cmath>
#include <string>

namespace vog::api {

namespace {

void boxToProto(const ExplorationBox& box, v1::Box& out) {
  out.set_min_x_m(box.min_world_m.x());
  out.set_min_y_m(box.min_world_m.y());
  out.set_min_z_m(box.min_world_m.z());
  out.set_max_x_m(box.max_world_m.x());
  out.set_max_y_m(box.max_world_m.y());
  out.set_max_z_m(box.max_world_m.z());
}

ExplorationBox boxFromProto(const v1::Box& b) {
  return {{b.min_x_m(), b.min_y_m(), b.min_z_m()}, {b.max_x_m(), b.max_y_m(), b.max_z_m()}};
}

std::string unknownEnum(std::string_view what, int value) {
  return "unknown " + std::string(what) + " value " + std::to_string(value);
}

}  // namespace

const char* toString(MissionState s) {
  switch (s) {
    case MissionState::kIdle: return "idle";
    case MissionState::kExploring: return "exploring";
    case MissionState::kReturning: return "returning";
    case MissionState::kComplete: return "complete";
    case MissionState::kPaused: return "paused";
    case MissionState::kAborted: return "aborted";
    case MissionState::kNearHome: return "near_home";
  }
  return "?";
}

const char* toString(PlannerState s) {
  switch (s) {
    case PlannerState::kIdle: return "idle";
    case PlannerState::kPlanning: return "planning";
    case PlannerState::kFollowing: return "following";
    case PlannerState::kFinished: return "finished";
    case PlannerState::kFailed: return "failed";
  }
  return "?";
}

const char* toString(DeviceState s) {
  switch (s) {
    case DeviceState::kOk: return "ok";
    case DeviceState::kDegraded: return "degraded";
    case DeviceState::kFailed: return "failed";
    case DeviceState::kDisconnected: return "disconnected";
  }
  return "?";
}

const char* toString(Role r) { return r == Role::kOperator ? "operator" : "observer"; }

const char* toString(MissionCommand::Kind k) {
  switch (k) {
    case MissionCommand::Kind::kSetBox: return "set-box";
    case MissionCommand::Kind::kStart: return "start";
    case MissionCommand::Kind::kPause: return "pause";
    case MissionCommand::Kind::kResume: return "resume";
    case MissionCommand::Kind::kAbort: return "abort";
    case MissionCommand::Kind::kReturnHome: return "return-home";
  }
  return "?";
}

Status ExplorationBox::validate() const {
  constexpr double kMaxSide_m = 10000.0;
  if (!min_world_m.allFinite() || !max_world_m.allFinite()) return Error{"box: corners must be finite"};
  for (int i = 0; i < 3; ++i) {
    const char* axis = i == 0 ? "x" : (i == 1 ? "y" : "z");
    if (!(min_world_m[i] < max_world_m[i])) {
      return Error{std::string("box: min_") + axis + "_m " + std::to_string(min_world_m[i]) + " must be below max_" +
                   axis + "_m " + std::to_string(max_world_m[i])};
    }
    if (max_world_m[i] - min_world_m[i] > kMaxSide_m) {
      return Error{std::string("box: ") + axis + " side " + std::to_string(max_world_m[i] - min_world_m[i]) +
                   " m exceeds 10000 m"};
    }
  }
  return {};
}

void toProto(const geometry::Pose3& T, v1::Pose& out) {
  const Eigen::Quaterniond q(T.linear());
  out.set_x_m(T.translation().x());
  out.set_y_m(T.translation().y());
  out.set_z_m(T.translation().z());
  out.set_qw(q.w());
  out.set_qx(q.x());
  out.set_qy(q.y());
  out.set_qz(q.z());
}

Result<geometry::Pose3> fromProto(const v1::Pose& pose, std::string_view field) {
  const Eigen::Vector3d t(pose.x_m(), pose.y_m(), pose.z_m());
  Eigen::Quaterniond q(pose.qw(), pose.qx(), pose.qy(), pose.qz());
  if (!t.allFinite() || !q.coeffs().allFinite()) return Error{std::string(field) + ": pose is not finite"};
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > 1e-3) {
    return Error{std::string(field) + ": quaternion norm " + std::to_string(norm) + " is not 1"};
  }
  q.normalize();
  geometry::Pose3 T = geometry::Pose3::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = t;
  return T;
}

v1::MissionState toProto(MissionState s) {
  switch (s) {
    case MissionState::kIdle: return v1::MISSION_STATE_IDLE;
    case MissionState::kExploring: return v1::MISSION_STATE_EXPLORING;
    case MissionState::kReturning: return v1::MISSION_STATE_RETURNING;
    case MissionState::kComplete: return v1::MISSION_STATE_COMPLETE;
    case MissionState::kPaused: return v1::MISSION_STATE_PAUSED;
    case MissionState::kAborted: return v1::MISSION_STATE_ABORTED;
    case MissionState::kNearHome: return v1::MISSION_STATE_NEAR_HOME;
  }
  return v1::MISSION_STATE_UNSPECIFIED;
}

Result<MissionState> fromProto(v1::MissionState s) {
  switch (s) {
    case v1::MISSION_STATE_IDLE: return MissionState::kIdle;
    case v1::MISSION_STATE_EXPLORING: return MissionState::kExploring;
    case v1::MISSION_STATE_RETURNING: return MissionState::kReturning;
    case v1::MISSION_STATE_COMPLETE: return MissionState::kComplete;
    case v1::MISSION_STATE_PAUSED: return MissionState::kPaused;
    case v1::MISSION_STATE_ABORTED: return MissionState::kAborted;
    case v1::MISSION_STATE_NEAR_HOME: return MissionState::kNearHome;
    default: return Error{unknownEnum("mission_state", s)};
  }
}

v1::PlannerState toProto(PlannerState s) {
  switch (s) {
    case PlannerState::kIdle: return v1::PLANNER_STATE_IDLE;
    case PlannerState::kPlanning: return v1::PLANNER_STATE_PLANNING;
    case PlannerState::kFollowing: return v1::PLANNER_STATE_FOLLOWING;
    case PlannerState::kFinished: return v1::PLANNER_STATE_FINISHED;
    case PlannerState::kFailed: return v1::PLANNER_STATE_FAILED;
  }
  return v1::PLANNER_STATE_UNSPECIFIED;
}

Result<PlannerState> fromProto(v1::PlannerState s) {
  switch (s) {
    case v1::PLANNER_STATE_IDLE: return PlannerState::kIdle;
    case v1::PLANNER_STATE_PLANNING: return PlannerState::kPlanning;
    case v1::PLANNER_STATE_FOLLOWING: return PlannerState::kFollowing;
    case v1::PLANNER_STATE_FINISHED: return PlannerState::kFinished;
    case v1::PLANNER_STATE_FAILED: return PlannerState::kFailed;
    default: return Error{unknownEnum("planner_state", s)};
  }
}

v1::DeviceState toProto(DeviceState s) {
  switch (s) {
    case DeviceState::kOk: return v1::DEVICE_STATE_OK;
    case DeviceState::kDegraded: return v1::DEVICE_STATE_DEGRADED;
    case DeviceState::kFailed: return v1::DEVICE_STATE_FAILED;
    case DeviceState::kDisconnected: return v1::DEVICE_STATE_DISCONNECTED;
  }
  return v1::DEVICE_STATE_UNSPECIFIED;
}

Result<DeviceState> fromProto(v1::DeviceState s) {
  switch (s) {
    case v1::DEVICE_STATE_OK: return DeviceState::kOk;
    case v1::DEVICE_STATE_DEGRADED: return DeviceState::kDegraded;
    case v1::DEVICE_STATE_FAILED: return DeviceState::kFailed;
    case v1::DEVICE_STATE_DISCONNECTED: return DeviceState::kDisconnected;
    default: return Error{unknownEnum("device state", s)};
  }
}

v1::Role toProto(Role r) { return r == Role::kOperator ? v1::ROLE_OPERATOR : v1::ROLE_OBSERVER; }

Result<Role> fromProto(v1::Role r) {
  switch (r) {
    case v1::ROLE_OBSERVER: return Role::kObserver;
    case v1::ROLE_OPERATOR: return Role::kOperator;
    default: return Error{unknownEnum("role", r)};
  }
}

void toProto(const StatusReport& status, v1::StatusReport& out) {
  out.set_stamp_ns(status.stamp_ns);
  out.set_mission_state(toProto(status.mission_state));
  toProto(status.T_world_vehicle, *out.mutable_pose());
  out.set_sigma_x_m(status.sigma_xyz_m.x());
  out.set_sigma_y_m(status.sigma_xyz_m.y());
  out.set_sigma_z_m(status.sigma_xyz_m.z());
  out.set_sigma_yaw_rad(status.sigma_yaw_rad);
  out.clear_devices();
  for (const DeviceHealth& d : status.devices) {
    auto* pd = out.add_devices();
    pd->set_name(d.name);
    pd->set_state(toProto(d.state));
    pd->set_detail(d.detail);
    pd->set_last_stamp_ns(d.last_stamp_ns);
    pd->set_messages(d.messages);
    pd->set_errors(d.errors);
  }
  out.set_n_submaps(status.n_submaps);
  out.set_n_closures(status.n_closures);
  out.set_planner_state(toProto(status.planner_state));
  out.set_map_version(status.map_version);
  out.set_graph_version(status.graph_version);
  if (status.box) {
    boxToProto(*status.box, *out.mutable_box());
  } else {
    out.clear_box();
  }
}

Result<StatusReport> fromProto(const v1::StatusReport& status) {
  StatusReport out;
  out.stamp_ns = status.stamp_ns();
  auto mission = fromProto(status.mission_state());
  if (!mission) return mission.error();
  out.mission_state = *mission;
  auto pose = fromProto(status.pose(), "status.pose");
  if (!pose) return pose.error();
  out.T_world_vehicle = *pose;
  out.sigma_xyz_m = {status.sigma_x_m(), status.sigma_y_m(), status.sigma_z_m()};
  out.sigma_yaw_rad = status.sigma_yaw_rad();
  for (const auto& d : status.devices()) {
    auto state = fromProto(d.state());
    if (!state) return Error{"device '" + d.name() + "': " + state.error().message};
    out.devices.push_back({d.name(), *state, d.detail(), d.last_stamp_ns(), d.messages(), d.errors()});
  }
  out.n_submaps = status.n_submaps();
  out.n_closures = status.n_closures();
  auto planner = fromProto(status.planner_state());
  if (!planner) return planner.error();
  out.planner_state = *planner;
  out.map_version = status.map_version();
  out.graph_version = status.graph_version();
  if (status.has_box()) {
    const ExplorationBox box = boxFromProto(status.box());
    if (auto st = box.validate(); !st) return Error{"status.box: " + st.error().message};
    out.box = box;
  }
  return out;
}

void toProto(const SubmapInfo& info, v1::SubmapInfo& out) {
  out.set_id(info.id);
  toProto(info.T_world_submap, *out.mutable_pose());
  out.set_n_scans(info.n_scans);
  out.set_first_stamp_ns(info.first_stamp_ns);
  out.set_last_stamp_ns(info.last_stamp_ns);
  out.set_closed(info.closed);
}

Result<SubmapInfo> fromProto(const v1::SubmapInfo& info) {
  auto pose = fromProto(info.pose(), "submap.pose");
  if (!pose) return Error{"submap " + std::to_string(info.id()) + ": " + pose.error().message};
  return SubmapInfo{info.id(), *pose, info.n_scans(), info.first_stamp_ns(), info.last_stamp_ns(), info.closed()};
}

void toProto(const Waypoint& w, v1::Waypoint& out) {
  out.set_seq(w.seq);
  out.set_stamp_ns(w.stamp_ns);
  toProto(w.T_world_target, *out.mutable_target());
  out.set_speed_mps(w.speed_mps);
  out.set_dropped(w.dropped);
  out.set_published_unix_ns(w.published_unix_ns);
}

Result<Waypoint> fromProto(const v1::Waypoint& w) {
  auto pose = fromProto(w.target(), "waypoint.target");
  if (!pose) return pose.error();
  if (!std::isfinite(w.speed_mps())) return Error{"waypoint.speed_mps is not finite"};
  return Waypoint{w.seq(), w.stamp_ns(), *pose, w.speed_mps(), w.dropped(), w.published_unix_ns()};
}

void toProto(const PoseUpdate& p, v1::PoseUpdate& out) {
  out.set_seq(p.seq);
  out.set_stamp_ns(p.stamp_ns);
  toProto(p.T_world_vehicle, *out.mutable_pose());
  out.set_dropped(p.dropped);
  out.set_published_unix_ns(p.published_unix_ns);
}

Result<PoseUpdate> fromProto(const v1::PoseUpdate& p) {
  auto pose = fromProto(p.pose(), "pose_update.pose");
  if (!pose) return pose.error();
  return PoseUpdate{p.seq(), p.stamp_ns(), *pose, p.dropped(), p.published_unix_ns()};
}

void toProto(const StatusUpdate& s, v1::StatusUpdate& out) {
  out.set_seq(s.seq);
  toProto(s.status, *out.mutable_status());
  out.set_dropped(s.dropped);
}

Result<StatusUpdate> fromProto(const v1::StatusUpdate& s) {
  auto status = fromProto(s.status());
  if (!status) return status.error();
  return StatusUpdate{s.seq(), std::move(*status), s.dropped()};
}

void toProto(const MissionCommand& command, v1::MissionCommand& out) {
  switch (command.kind) {
    case MissionCommand::Kind::kSetBox: out.set_kind(v1::MissionCommand::KIND_SET_BOX); break;
    case MissionCommand::Kind::kStart: out.set_kind(v1::MissionCommand::KIND_START); break;
    case MissionCommand::Kind::kPause: out.set_kind(v1::MissionCommand::KIND_PAUSE); break;
    case MissionCommand::Kind::kResume: out.set_kind(v1::MissionCommand::KIND_RESUME); break;
    case MissionCommand::Kind::kAbort: out.set_kind(v1::MissionCommand::KIND_ABORT); break;
    case MissionCommand::Kind::kReturnHome: out.set_kind(v1::MissionCommand::KIND_RETURN_HOME); break;
  }
  if (command.kind == MissionCommand::Kind::kSetBox) {
    boxToProto(command.box, *out.mutable_box());
  }
}

Result<MissionCommand> fromProto(const v1::MissionCommand& command) {
  MissionCommand out;
  switch (command.kind()) {
    case v1::MissionCommand::KIND_SET_BOX: out.kind = MissionCommand::Kind::kSetBox; break;
    case v1::MissionCommand::KIND_START: out.kind = MissionCommand::Kind::kStart; break;
    case v1::MissionCommand::KIND_PAUSE: out.kind = MissionCommand::Kind::kPause; break;
    case v1::MissionCommand::KIND_RESUME: out.kind = MissionCommand::Kind::kResume; break;
    case v1::MissionCommand::KIND_ABORT: out.kind = MissionCommand::Kind::kAbort; break;
    case v1::MissionCommand::KIND_RETURN_HOME: out.kind = MissionCommand::Kind::kReturnHome; break;
    default: return Error{unknownEnum("mission_command.kind", command.kind())};
  }
  if (out.kind == MissionCommand::Kind::kSetBox) {
    if (!command.has_box()) return Error{"mission_command.box is required for set-box"};
    out.box = boxFromProto(command.box());
    if (Status s = out.box.validate(); !s.ok()) return Error{"mission_command." + s.error().message};
  }
  return out;
}

}  // namespace vog::api
