#include "vog/mission/journal.hpp"

#include "byte_codec.hpp"

#include <type_traits>

namespace vog::mission {
namespace {

using detail::readMatrix;
using detail::readPose;
using detail::writeMatrix;
using detail::writePose;

constexpr int kMaxPartialRank = 6;

void encodeBody(ByteWriter& w, const SubmapClosedRecord& r) {
  w.u8(static_cast<std::uint8_t>(RecordType::kSubmapClosed));
  w.i64(r.index);
  w.i64(r.first_stamp_ns);
  w.i64(r.last_stamp_ns);
  w.u64(r.n_scans);
  w.u8(static_cast<std::uint8_t>(r.reason));
  writePose(w, r.T_world_base_odom);
  writeMatrix(w, r.base_z_roll_pitch);
  w.u8(r.has_previous ? 1 : 0);
  writeMatrix(w, r.odometry_from_previous);
  writeMatrix(w, r.odometry_covariance);
  w.string16(r.ot_file);
  w.u64(r.ot_size_bytes);
  w.u32(r.ot_crc32c);
  w.u32(static_cast<std::uint32_t>(r.sensor_origins.size()));
  for (const Eigen::Vector3d& o : r.sensor_origins) writeMatrix(w, o);
}

void encodeBody(ByteWriter& w, const LoopClosureRecord& r) {
  w.u8(static_cast<std::uint8_t>(RecordType::kLoopClosure));
  w.i64(r.from);
  w.i64(r.to);
  writePose(w, r.T_from_to);
  writePose(w, r.T_from_to_prior);
  writeMatrix(w, r.factor.x_icp);
  w.u8(static_cast<std::uint8_t>(r.factor.rank()));
  writeMatrix(w, r.factor.V_u);
  writeMatrix(w, r.factor.measurement);
  writeMatrix(w, r.factor.covariance);
}

void encodeBody(ByteWriter& w, const OptimizedPosesRecord& r) {
  w.u8(static_cast<std::uint8_t>(RecordType::kOptimizedPoses));
  w.u32(static_cast<std::uint32_t>(r.estimates.size()));
  for (const auto& [id, x] : r.estimates) {
    w.i64(id);
    writeMatrix(w, x);
  }
}

void encodeBody(ByteWriter& w, const WaypointRecord& r) {
  w.u8(static_cast<std::uint8_t>(RecordType::kWaypointSent));
  w.i64(r.stamp_ns);
  w.f64(r.x_m);
  w.f64(r.y_m);
  w.f64(r.z_m);
  w.f64(r.yaw_rad);
}

void encodeBody(ByteWriter& w, const MissionStateRecord& r) {
  w.u8(static_cast<std::uint8_t>(RecordType::kMissionState));
  w.i64(r.stamp_ns);
  w.u8(static_cast<std::uint8_t>(r.state));
}

// Shared checks after the fields were read: the payload was long enough and nothing is left over.
Status finish(const ByteReader& r, const char* type) {
  if (!r.ok()) return Error{std::string(type) + " record: " + r.error()};
  if (r.remaining() != 0) {
    return Error{std::string(type) + " record: " + std::to_string(r.remaining()) + " unexpected trailing bytes"};
  }
  return Status::success();
}

Status checkPose(const geometry::Pose3& T, const char* type, const char* field) {
  if (!geometry::isValidPose(T)) return Error{std::string(type) + " record: " + field + " is not a finite rigid pose"};
  return Status::success();
}

template <class M>
Status checkFinite(const M& m, const char* type, const char* field) {
  if (!m.allFinite()) return Error{std::string(type) + " record: " + field + " is not finite"};
  return Status::success();
}

Result<JournalRecord> decodeSubmapClosed(ByteReader& in, bool with_origins) {
  constexpr const char* kType = "submap-closed";
  SubmapClosedRecord r;
  r.index = in.i64("index");
  r.first_stamp_ns = in.i64("first_stamp_ns");
  r.last_stamp_ns = in.i64("last_stamp_ns");
  r.n_scans = in.u64("n_scans");
  const std::uint8_t reason = in.u8("reason");
  r.T_world_base_odom = readPose(in, "T_world_base_odom");
  readMatrix(in, r.base_z_roll_pitch, "base_z_roll_pitch");
  const std::uint8_t has_previous = in.u8("has_previous");
  readMatrix(in, r.odometry_from_previous, "odometry_from_previous");
  readMatrix(in, r.odometry_covariance, "odometry_covariance");
  r.ot_file = in.string16("ot_file");
  r.ot_size_bytes = in.u64("ot_size_bytes");
  r.ot_crc32c = in.u32("ot_crc32c");
  if (with_origins) {
    const std::uint32_t n_origins = in.u32("n_sensor_origins");
    constexpr std::size_t kOriginBytes = 3 * sizeof(double);
    if (in.ok() && in.remaining() < n_origins * kOriginBytes) {
      return Error{std::string(kType) + " record: " + std::to_string(n_origins) + " sensor origins need " +
                   std::to_string(n_origins * kOriginBytes) + " bytes, " + std::to_string(in.remaining()) + " remain"};
    }
    r.sensor_origins.resize(in.ok() ? n_origins : 0);
    for (Eigen::Vector3d& o : r.sensor_origins) readMatrix(in, o, "sensor_origins");
  }
  if (Status s = finish(in, kType); !s.ok()) return s.error();
  if (reason > static_cast<std::uint8_t>(slam::CloseReason::kFlush)) {
    return Error{std::string(kType) + " record: close reason " + std::to_string(reason) + " is not 0..3"};
  }
  r.reason = static_cast<slam::CloseReason>(reason);
  if (has_previous > 1) {
    return Error{std::string(kType) + " record: has_previous " + std::to_string(has_previous) + " is not 0 or 1"};
  }
  r.has_previous = has_previous == 1;
  if (r.index < 0) return Error{std::string(kType) + " record: negative index " + std::to_string(r.index)};
  if (Status s = checkPose(r.T_world_base_odom, kType, "T_world_base_odom"); !s.ok()) return s.error();
  if (Status s = checkFinite(r.base_z_roll_pitch, kType, "base_z_roll_pitch"); !s.ok()) return s.error();
  if (Status s = checkFinite(r.odometry_from_previous, kType, "odometry_from_previous"); !s.ok()) return s.error();
  if (Status s = checkFinite(r.odometry_covariance, kType, "odometry_covariance"); !s.ok()) return s.error();
  for (const Eigen::Vector3d& o : r.sensor_origins) {
    if (Status s = checkFinite(o, kType, "sensor_origins"); !s.ok()) return s.error();
  }
  return JournalRecord{std::move(r)};
}

Result<JournalRecord> decodeLoopClosure(ByteReader& in) {
  constexpr const char* kType = "loop-closure";
  LoopClosureRecord r;
  r.from = in.i64("from");
  r.to = in.i64("to");
  r.T_from_to = readPose(in, "T_from_to");
  r.T_from_to_prior = readPose(in, "T_from_to_prior");
  readMatrix(in, r.factor.x_icp, "x_icp");
  const int k = in.u8("rank");
  if (in.ok() && (k < 1 || k > kMaxPartialRank)) {
    return Error{std::string(kType) + " record: rank " + std::to_string(k) + " is not 1..6"};
  }
  r.factor.V_u = Eigen::MatrixXd::Zero(k, 6);
  r.factor.measurement = Eigen::VectorXd::Zero(k);
  r.factor.covariance = Eigen::MatrixXd::Zero(k, k);
  readMatrix(in, r.factor.V_u, "V_u");
  readMatrix(in, r.factor.measurement, "measurement");
  readMatrix(in, r.factor.covariance, "covariance");
  if (Status s = finish(in, kType); !s.ok()) return s.error();
  if (Status s = checkPose(r.T_from_to, kType, "T_from_to"); !s.ok()) return s.error();
  if (Status s = checkPose(r.T_from_to_prior, kType, "T_from_to_prior"); !s.ok()) return s.error();
  if (Status s = checkFinite(r.factor.x_icp, kType, "x_icp"); !s.ok()) return s.error();
  if (Status s = checkFinite(r.factor.V_u, kType, "V_u"); !s.ok()) return s.error();
  if (Status s = checkFinite(r.factor.measurement, kType, "measurement"); !s.ok()) return s.error();
  if (Status s = checkFinite(r.factor.covariance, kType, "covariance"); !s.ok()) return s.error();
  return JournalRecord{std::move(r)};
}

Result<JournalRecord> decodeOptimizedPoses(ByteReader& in) {
  constexpr const char* kType = "optimized-poses";
  constexpr std::size_t kEntryBytes = 8 + 6 * 8;
  OptimizedPosesRecord r;
  const std::uint32_t n = in.u32("count");
  if (in.ok() && n > in.remaining() / kEntryBytes) {
    return Error{std::string(kType) + " record: count " + std::to_string(n) + " exceeds the payload (" +
                 std::to_string(in.remaining()) + " bytes left)"};
  }
  r.estimates.reserve(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    slam::NodeId id = in.i64("node id");
    slam::Vector6d x;
    readMatrix(in, x, "estimate");
    r.estimates.emplace_back(id, x);
  }
  if (Status s = finish(in, kType); !s.ok()) return s.error();
  for (const auto& [id, x] : r.estimates) {
    if (!x.allFinite())
      return Error{std::string(kType) + " record: estimate of node " + std::to_string(id) + " is not finite"};
  }
  return JournalRecord{std::move(r)};
}

Result<JournalRecord> decodeWaypoint(ByteReader& in) {
  constexpr const char* kType = "waypoint-sent";
  WaypointRecord r;
  r.stamp_ns = in.i64("stamp_ns");
  r.x_m = in.f64("x_m");
  r.y_m = in.f64("y_m");
  r.z_m = in.f64("z_m");
  r.yaw_rad = in.f64("yaw_rad");
  if (Status s = finish(in, kType); !s.ok()) return s.error();
  if (!Eigen::Vector4d(r.x_m, r.y_m, r.z_m, r.yaw_rad).allFinite()) {
    return Error{std::string(kType) + " record: waypoint is not finite"};
  }
  return JournalRecord{r};
}

Result<JournalRecord> decodeMissionState(ByteReader& in) {
  constexpr const char* kType = "mission-state";
  MissionStateRecord r;
  r.stamp_ns = in.i64("stamp_ns");
  const std::uint8_t state = in.u8("state");
  if (Status s = finish(in, kType); !s.ok()) return s.error();
  if (state > static_cast<std::uint8_t>(MissionState::kNearHome)) {
    return Error{std::string(kType) + " record: state " + std::to_string(state) + " is not 0..6"};
  }
  r.state = static_cast<MissionState>(state);
  return JournalRecord{r};
}

}  // namespace

const char* toString(MissionState state) {
  switch (state) {
    case MissionState::kIdle: return "idle";
    case MissionState::kExploring: return "exploring";
    case MissionState::kReturning: return "returning";
    case MissionState::kComplete: return "complete";
    case MissionState::kPaused: return "paused";
    case MissionState::kAborted: return "aborted";
    case MissionState::kNearHome: return "near_home";
  }
  return "unknown";
}

std::vector<std::uint8_t> encodeRecord(const JournalRecord& record) {
  std::vector<std::uint8_t> out;
  ByteWriter w(out);
  std::visit([&w](const auto& r) { encodeBody(w, r); }, record);
  return out;
}

Result<JournalRecord> decodeRecord(std::span<const std::uint8_t> payload) {
  if (payload.empty()) return Error{"empty record payload"};
  ByteReader in(payload.subspan(1));
  switch (payload[0]) {
    case static_cast<std::uint8_t>(RecordType::kSubmapClosedWithoutOrigins): return decodeSubmapClosed(in, false);
    case static_cast<std::uint8_t>(RecordType::kSubmapClosed): return decodeSubmapClosed(in, true);
    case static_cast<std::uint8_t>(RecordType::kLoopClosure): return decodeLoopClosure(in);
    case static_cast<std::uint8_t>(RecordType::kOptimizedPoses): return decodeOptimizedPoses(in);
    case static_cast<std::uint8_t>(RecordType::kWaypointSent): return decodeWaypoint(in);
    case static_cast<std::uint8_t>(RecordType::kMissionState): return decodeMissionState(in);
    default: break;
  }
  return Error{"unknown record type " + std::to_string(payload[0])};
}

Result<JournalContents> decodeJournal(RecordScan scan, const std::string& what) {
  JournalContents out;
  out.tail = scan.tail;
  out.good_end = scan.good_end;
  out.entries.reserve(scan.records.size());
  for (const FramedRecord& f : scan.records) {
    auto record = decodeRecord(f.payload);
    if (!record) {
      return Error{what + ": record at byte offset " + std::to_string(f.offset) + ": " + record.error().message};
    }
    out.entries.push_back({f.offset, std::move(record.value())});
  }
  return out;
}

Result<JournalContents> readJournal(const std::filesystem::path& path) {
  auto scan = readRecordFile(path);
  if (!scan) return scan.error();
  return decodeJournal(std::move(scan.value()), path.string());
}

Result<std::unique_ptr<Journal>> Journal::open(const std::filesystem::path& path, JournalContents* existing) {
  RecordScan scan;
  auto writer = RecordWriter::open(path, &scan);
  if (!writer) return writer.error();
  auto contents = decodeJournal(std::move(scan), path.string());
  if (!contents) return contents.error();
  if (existing != nullptr) *existing = std::move(contents.value());
  return std::unique_ptr<Journal>(new Journal(std::move(writer.value())));
}

Status Journal::append(const JournalRecord& record) { return writer_->append(encodeRecord(record)); }

}  // namespace vog::mission
