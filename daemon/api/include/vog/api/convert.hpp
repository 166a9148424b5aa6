#pragma once
// vog.v1 messages <-> domain types (vog/api/domain.hpp), at the edge (DESIGN: "api converts protobuf
// to domain types"). Every fromProto validates what came over the wire and names the bad field.

#include "vog/api/domain.hpp"
#include "vog/v1/api.pb.h"

namespace vog::api {

void toProto(const geometry::Pose3& T, v1::Pose& out);
// Finite position and a quaternion of norm within 1e-3 of 1 (normalized on the way in).
Result<geometry::Pose3> fromProto(const v1::Pose& pose, std::string_view field);

v1::MissionState toProto(MissionState s);
Result<MissionState> fromProto(v1::MissionState s);
v1::PlannerState toProto(PlannerState s);
Result<PlannerState> fromProto(v1::PlannerState s);
v1::DeviceState toProto(DeviceState s);
Result<DeviceState> fromProto(v1::DeviceState s);
v1::Role toProto(Role r);
Result<Role> fromProto(v1::Role r);

void toProto(const StatusReport& status, v1::StatusReport& out);
Result<StatusReport> fromProto(const v1::StatusReport& status);

void toProto(const SubmapInfo& info, v1::SubmapInfo& out);
Result<SubmapInfo> fromProto(const v1::SubmapInfo& info);

void toProto(const Waypoint& w, v1::Waypoint& out);
Result<Waypoint> fromProto(const v1::Waypoint& w);
void toProto(const PoseUpdate& p, v1::PoseUpdate& out);
Result<PoseUpdate> fromProto(const v1::PoseUpdate& p);
void toProto(const StatusUpdate& s, v1::StatusUpdate& out);
Result<StatusUpdate> fromProto(const v1::StatusUpdate& s);

void toProto(const MissionCommand& command, v1::MissionCommand& out);
// Rejects an unspecified kind and a set-box command whose box is invalid.
Result<MissionCommand> fromProto(const v1::MissionCommand& command);

}  // namespace vog::api
