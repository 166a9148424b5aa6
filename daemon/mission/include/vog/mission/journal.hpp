#pragma once
// The mission journal: an append-only record file (record_file.hpp framing) of everything needed to
// rebuild the pose graph and resume the mission. Payload = one type byte + fields, little-endian; the
// byte layout of every type is in daemon/mission/README.md. Records of one closed submap form a group
// written together by MissionStore: SubmapClosed, its LoopClosure records, then OptimizedPoses, which
// commits the group.
#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/mission/record_file.hpp"
#include "vog/slam/pose_graph.hpp"
#include "vog/slam/pose_vector.hpp"
#include "vog/slam/submap_builder.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace vog::mission {

enum class RecordType : std::uint8_t {
  kSubmapClosedWithoutOrigins = 1,  // the layout before sensor origins were recorded: read, never written
  kLoopClosure = 2,
  kOptimizedPoses = 3,
  kWaypointSent = 4,
  kMissionState = 5,
  kSubmapClosed = 6,  // type 1's fields, then the grid's sensor origins
};

// A closed submap: the builder's output minus the grid, which lives in `ot_file` (relative to the
// mission's submaps/ directory) with the given size and CRC-32C so that a damaged file is detected,
// and the grid's sensor origins, which the .ot file cannot hold (empty in journals written before they
// were recorded: such a grid orients its normals towards its base).
struct SubmapClosedRecord {
  std::int64_t index = 0;
  std::int64_t first_stamp_ns = 0;
  std::int64_t last_stamp_ns = 0;
  std::uint64_t n_scans = 0;
  slam::CloseReason reason = slam::CloseReason::kFlush;
  geometry::Pose3 T_world_base_odom = geometry::Pose3::Identity();
  Eigen::Vector3d base_z_roll_pitch = Eigen::Vector3d::Zero();
  bool has_previous = false;
  Eigen::Vector3d odometry_from_previous = Eigen::Vector3d::Zero();  // dx, dy, dyaw
  Eigen::Matrix3d odometry_covariance = Eigen::Matrix3d::Zero();
  std::string ot_file;
  std::uint64_t ot_size_bytes = 0;
  std::uint32_t ot_crc32c = 0;
  std::vector<Eigen::Vector3d> sensor_origins;  // LocalGrid::sensorOrigins(), grid frame
};

// An accepted loop closure and its partial factor (thesis Alg. 8).
struct LoopClosureRecord {
  std::int64_t from = 0;
  std::int64_t to = 0;
  geometry::Pose3 T_from_to = geometry::Pose3::Identity();
  geometry::Pose3 T_from_to_prior = geometry::Pose3::Identity();
  slam::PartialLoopClosure factor;
};

// Graph estimates (x, y, z, roll, pitch, yaw as PoseGraph::estimate()) after processing a submap: all
// nodes after an optimisation, else only the new one.
struct OptimizedPosesRecord {
  std::vector<std::pair<slam::NodeId, slam::Vector6d>> estimates;
};

struct WaypointRecord {
  std::int64_t stamp_ns = 0;
  double x_m = 0.0;
  double y_m = 0.0;
  double z_m = 0.0;
  double yaw_rad = 0.0;
};

// Mission lifecycle; same values as the API's MissionState. kNearHome: the exploration is complete,
// home was not reachable through known free space, the vehicle waits at the reachable safe position
// nearest to it.
enum class MissionState : std::uint8_t { kIdle, kExploring, kReturning, kComplete, kPaused, kAborted, kNearHome };
const char* toString(MissionState state);

struct MissionStateRecord {
  std::int64_t stamp_ns = 0;
  MissionState state = MissionState::kIdle;
};

using JournalRecord =
    std::variant<SubmapClosedRecord, LoopClosureRecord, OptimizedPosesRecord, WaypointRecord, MissionStateRecord>;

std::vector<std::uint8_t> encodeRecord(const JournalRecord& record);
// Decodes one payload; errors name the record type and field (unknown type, short payload, trailing
// bytes, an out-of-range enum, a non-finite value or a non-rigid pose).
Result<JournalRecord> decodeRecord(std::span<const std::uint8_t> payload);

struct JournalEntry {
  std::uint64_t offset = 0;  // byte offset of the record's frame
  JournalRecord record;
};

struct JournalContents {
  std::vector<JournalEntry> entries;
  TailRecovery tail;  // a torn last record, discarded
  std::uint64_t good_end = 0;
};

// Reads a journal without changing it. Corruption in the middle or a record that does not decode is an
// error naming the byte offset.
Result<JournalContents> readJournal(const std::filesystem::path& path);
// Decodes already framed records (shared by readJournal and Journal::open).
Result<JournalContents> decodeJournal(RecordScan scan, const std::string& what);

// Appending side. Lifecycle: open() reads and decodes what is there (truncating a torn tail), then
// append() buffers and sync() makes everything appended durable. Not thread-safe.
class Journal {
 public:
  static Result<std::unique_ptr<Journal>> open(const std::filesystem::path& path, JournalContents* existing = nullptr);
  Status append(const JournalRecord& record);
  Status sync() { return writer_->sync(); }
  // Drops every record at or after `offset` (a JournalEntry::offset).
  Status truncate(std::uint64_t offset) { return writer_->truncate(offset); }
  // Forgets the records after `size_bytes` (an earlier sizeBytes()) and clears a write failure
  // (RecordWriter::rollback), so that they can be appended again.
  Status rollback(std::uint64_t size_bytes) { return writer_->rollback(size_bytes); }
  std::uint64_t sizeBytes() const { return writer_->sizeBytes(); }

 private:
  explicit Journal(std::unique_ptr<RecordWriter> writer) : writer_(std::move(writer)) {}
  std::unique_ptr<RecordWriter> writer_;
};

}  // namespace vog::mission
