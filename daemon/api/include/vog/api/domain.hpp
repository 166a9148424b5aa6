#pragma once
// The domain side of vogd's API: plain C++ types (no protobuf) that the daemon fills and the client
// library returns, and the `ApiBackend` interface the daemon implements. proto/vog/v1/api.proto is
// the wire form; vog/api/convert.hpp maps one to the other at the edge (STYLE 14).

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/map/merged_map.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace vog::api {

// Mission lifecycle: idle -> exploring -> returning -> complete (or near_home: home was not reachable
// through known free space, the vehicle waits at the reachable safe position nearest to it), plus
// paused and aborted.
enum class MissionState : std::uint8_t { kIdle, kExploring, kReturning, kComplete, kPaused, kAborted, kNearHome };
enum class PlannerState : std::uint8_t { kIdle, kPlanning, kFollowing, kFinished, kFailed };
enum class DeviceState : std::uint8_t { kOk, kDegraded, kFailed, kDisconnected };
enum class Role : std::uint8_t { kObserver, kOperator };

const char* toString(MissionState s);
const char* toString(PlannerState s);
const char* toString(DeviceState s);
const char* toString(Role r);

struct DeviceHealth {
  std::string name;
  DeviceState state = DeviceState::kOk;
  std::string detail;
  std::int64_t last_stamp_ns = 0;
  std::uint64_t messages = 0;
  std::uint64_t errors = 0;
};

// Exploration box in the world frame.
struct ExplorationBox {
  Eigen::Vector3d min_world_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_world_m = Eigen::Vector3d::Zero();

  // Finite corners with min < max on every axis, each side at most 10 km.
  Status validate() const;
};

struct StatusReport {
  std::int64_t stamp_ns = 0;
  MissionState mission_state = MissionState::kIdle;
  geometry::Pose3 T_world_vehicle = geometry::Pose3::Identity();
  Eigen::Vector3d sigma_xyz_m = Eigen::Vector3d::Zero();
  double sigma_yaw_rad = 0.0;
  std::vector<DeviceHealth> devices;
  std::uint32_t n_submaps = 0;
  std::uint32_t n_closures = 0;
  PlannerState planner_state = PlannerState::kIdle;
  std::uint64_t map_version = 0;
  std::uint64_t graph_version = 0;
  std::optional<ExplorationBox> box;  // none while no box is set
};

struct SubmapInfo {
  std::uint32_t id = 0;
  geometry::Pose3 T_world_submap = geometry::Pose3::Identity();
  std::uint32_t n_scans = 0;
  std::int64_t first_stamp_ns = 0;
  std::int64_t last_stamp_ns = 0;
  bool closed = false;
};

// A reconstruction point in the world frame; normal is zero when not computed.
struct CloudPoint {
  Eigen::Vector3f p_world_m = Eigen::Vector3f::Zero();
  Eigen::Vector3f normal_world = Eigen::Vector3f::Zero();
};
using Cloud = std::vector<CloudPoint>;
// The reconstruction GetCloud serves: the cloud and the merged map's version it was built from.
struct ServedCloud {
  std::uint64_t map_version = 0;
  Cloud points;
};

struct Waypoint {
  std::uint64_t seq = 0;  // assigned by ApiServer::publishWaypoint (1, 2, ...)
  std::int64_t stamp_ns = 0;
  geometry::Pose3 T_world_target = geometry::Pose3::Identity();
  double speed_mps = 0.0;
  std::uint64_t dropped = 0;           // filled on the client side: waypoints this session lost so far
  std::int64_t published_unix_ns = 0;  // set by ApiServer::publishWaypoint: its wall clock (Unix ns)
};

struct PoseUpdate {
  std::uint64_t seq = 0;
  std::int64_t stamp_ns = 0;
  geometry::Pose3 T_world_vehicle = geometry::Pose3::Identity();
  std::uint64_t dropped = 0;
  std::int64_t published_unix_ns = 0;  // set by ApiServer::publishPose: its wall clock (Unix ns)
};

struct StatusUpdate {
  std::uint64_t seq = 0;
  StatusReport status;
  std::uint64_t dropped = 0;
};

struct MissionCommand {
  enum class Kind : std::uint8_t { kSetBox, kStart, kPause, kResume, kAbort, kReturnHome };
  Kind kind = Kind::kStart;
  ExplorationBox box;  // used by kSetBox only
};
const char* toString(MissionCommand::Kind k);

struct Subscriptions {
  bool waypoints = false;
  bool poses = false;
  bool status = false;
  bool graph = false;
};

// The pose graph as the API serves it (vog/api/graph.hpp): every closed submap's base pose, the exact
// matrix the merged map uses, and the submap pairs of the loop closures. `version` counts changes
// (1, 2, ... per daemon run). Immutable once published.
struct SubmapPose {
  std::uint32_t id = 0;
  geometry::Pose3 T_world_submap = geometry::Pose3::Identity();
};
struct ClosurePair {
  std::uint32_t from = 0;
  std::uint32_t to = 0;
  bool operator==(const ClosurePair&) const = default;
};
struct GraphState {
  std::uint64_t version = 0;
  std::int64_t stamp_ns = 0;
  std::vector<SubmapPose> submaps;  // ascending id
  std::vector<ClosurePair> closures;
};

// What vogd gives the API. Every method is called on the API's io_context thread, so each must be
// cheap: hand out immutable snapshots (the merged map's shared_ptr<const>), copies of small state,
// or enqueue a command for the mission thread and return its accepted state.
class ApiBackend {
 public:
  virtual ~ApiBackend() = default;
  virtual StatusReport status() const = 0;
  // The newest merged-map snapshot; null while there is no map yet.
  virtual std::shared_ptr<const map::MergedMap> mapSnapshot() const = 0;
  virtual std::vector<SubmapInfo> submaps() const = 0;
  // The newest pose graph (null before the first); GetGraph and the graph stream serve it.
  virtual std::shared_ptr<const GraphState> graph() const = 0;
  // A closed submap's grid (immutable), null when no closed submap has this id.
  virtual std::shared_ptr<const map::LocalGrid> submapGrid(std::uint32_t id) const = 0;
  // The newest reconstruction built so far (it may lag the newest map version); null while there is
  // none. Never builds one on the calling (io) thread.
  virtual std::shared_ptr<const ServedCloud> cloud() const = 0;
  // An operator's command (already authenticated and validated): the mission state after it, or an
  // error saying why the mission refused it (e.g. "start while exploring").
  virtual Result<MissionState> command(const MissionCommand& command) = 0;
  virtual std::string configText() const = 0;
};

// Library code never prints: the server reports security-relevant and connection events here.
enum class LogLevel : std::uint8_t { kDebug, kInfo, kWarning, kError };
class ApiLogger {
 public:
  virtual ~ApiLogger() = default;
  virtual void log(LogLevel level, std::string_view message) = 0;
};

}  // namespace vog::api
