#include "vog/api/dispatcher.hpp"

#include "vog/api/convert.hpp"
#include "vog/api/framing.hpp"
#include "vog/api/graph.hpp"
#include "vog/api/map_delta.hpp"
#include "vog/api/submap_transfer.hpp"
#include "vog/v1/map.pb.h"

#include <algorithm>

namespace vog::api {

namespace {

Reply single(v1::Envelope envelope) {
  Reply r;
  r.frames.push_back(std::move(envelope));
  return r;
}

Reply errorReply(std::uint64_t id, v1::ErrorCode code, std::string message, bool disconnect = false) {
  Reply r = single(makeError(id, code, std::move(message)));
  r.disconnect = disconnect;
  return r;
}

// Map transfer from the held immutable snapshot (proto/README.md "GetMap"): the block list is taken
// when the first chunk is asked for (a transfer queued behind others holds only the snapshot), and
// each chunk encodes only its own blocks, so no transfer ever holds the encoded map. The removed keys
// come first, then the changed blocks, in the order of blocksChangedSince: the same frames as slicing
// encodeMapDelta's result.
class MapChunks final : public ChunkSource {
 public:
  MapChunks(std::uint64_t id, std::shared_ptr<const map::MergedMap> snapshot, std::uint64_t since_version,
            std::size_t blocks_per_chunk)
      : id_(id),
        snapshot_(std::move(snapshot)),
        since_version_(since_version),
        blocks_per_chunk_(blocks_per_chunk),
        // A removed key costs at most 20 bytes on the wire, a block about 2150: 64 keys per block slot.
        removed_per_chunk_(blocks_per_chunk * 64) {}

  bool done() const override { return started_ && index_ >= count_; }
  std::uint64_t requestId() const override { return id_; }

  v1::Envelope next() override {
    if (!started_) start();
    v1::Envelope out;
    out.set_request_id(id_);
    auto* chunk = out.mutable_map_chunk();
    chunk->set_chunk_index(static_cast<std::uint32_t>(index_));
    chunk->set_chunk_count(static_cast<std::uint32_t>(count_));
    chunk->set_blocks_total(static_cast<std::uint64_t>(changed_.size()));
    chunk->set_removed_total(static_cast<std::uint64_t>(removed_.size()));
    auto* delta = chunk->mutable_delta();
    encodeDeltaHeader(*snapshot_, since_version_, *delta);
    if (removed_at_ < removed_.size()) {
      const std::size_t end = std::min(removed_.size(), removed_at_ + removed_per_chunk_);
      for (; removed_at_ < end; ++removed_at_) encodeRemoved(removed_[removed_at_], *delta->add_removed());
    } else {
      const std::size_t end = std::min(changed_.size(), changed_at_ + blocks_per_chunk_);
      for (; changed_at_ < end; ++changed_at_) {
        encodeBlock(bounds_, changed_[changed_at_].first, *changed_[changed_at_].second, *delta->add_changed());
        changed_[changed_at_].second.reset();  // sent: the snapshot may go once the transfer ends
      }
    }
    ++index_;
    return out;
  }

 private:
  void start() {
    started_ = true;
    bounds_ = snapshot_->config().bounds();
    changed_ = snapshot_->blocksChangedSince(since_version_);
    removed_ = snapshot_->blocksRemovedSince(since_version_);
    const std::size_t removed_chunks = (removed_.size() + removed_per_chunk_ - 1) / removed_per_chunk_;
    const std::size_t changed_chunks = (changed_.size() + blocks_per_chunk_ - 1) / blocks_per_chunk_;
    count_ = std::max<std::size_t>(1, removed_chunks + changed_chunks);
  }

  std::uint64_t id_;
  std::shared_ptr<const map::MergedMap> snapshot_;
  std::uint64_t since_version_;
  std::size_t blocks_per_chunk_;
  std::size_t removed_per_chunk_;
  bool started_ = false;
  map::LogOddsBounds bounds_;
  std::vector<std::pair<map::VoxelKey, std::shared_ptr<const map::MergedMap::Block>>> changed_;
  std::vector<map::VoxelKey> removed_;
  std::size_t count_ = 1;
  std::size_t index_ = 0;
  std::size_t removed_at_ = 0;
  std::size_t changed_at_ = 0;
};

class CloudChunks final : public ChunkSource {
 public:
  CloudChunks(std::uint64_t id, std::shared_ptr<const ServedCloud> served, std::size_t points_per_chunk)
      : id_(id), served_(std::move(served)), cloud_(&served_->points), per_chunk_(points_per_chunk) {
    count_ = std::max<std::size_t>(1, (cloud_->size() + per_chunk_ - 1) / per_chunk_);
    for (const CloudPoint& p : *cloud_) has_normals_ = has_normals_ || !p.normal_world.isZero();
  }

  bool done() const override { return index_ >= count_; }
  std::uint64_t requestId() const override { return id_; }

  v1::Envelope next() override {
    v1::Envelope out;
    out.set_request_id(id_);
    auto* chunk = out.mutable_cloud_chunk();
    chunk->set_chunk_index(static_cast<std::uint32_t>(index_));
    chunk->set_chunk_count(static_cast<std::uint32_t>(count_));
    chunk->set_points_total(cloud_->size());
    chunk->set_map_version(served_->map_version);
    const std::size_t begin = index_ * per_chunk_;
    const std::size_t end = std::min(cloud_->size(), begin + per_chunk_);
    chunk->mutable_xyz_m()->Reserve(static_cast<int>(3 * (end - begin)));
    if (has_normals_) chunk->mutable_normals()->Reserve(static_cast<int>(3 * (end - begin)));
    for (std::size_t i = begin; i < end; ++i) {
      const CloudPoint& p = (*cloud_)[i];
      for (int k = 0; k < 3; ++k) chunk->add_xyz_m(p.p_world_m[k]);
      if (has_normals_) {
        for (int k = 0; k < 3; ++k) chunk->add_normals(p.normal_world[k]);
      }
    }
    ++index_;
    return out;
  }

 private:
  std::uint64_t id_;
  std::shared_ptr<const ServedCloud> served_;
  const Cloud* cloud_;  // served_->points
  std::size_t per_chunk_;
  std::size_t count_ = 1;
  std::size_t index_ = 0;
  bool has_normals_ = false;
};

}  // namespace

Status DispatchConfig::validate() const {
  if (max_frame_bytes < 64 * 1024 || max_frame_bytes > kFrameBytesLimit) {
    return Error{"api.max_frame_bytes: " + std::to_string(max_frame_bytes) + " is outside [65536, " +
                 std::to_string(kFrameBytesLimit) + "]"};
  }
  if (!operator_secret.empty() && operator_secret.size() < 16) {
    return Error{"api.operator_secret: " + std::to_string(operator_secret.size()) +
                 " bytes is too short (at least 16, or empty to disable the operator role)"};
  }
  const std::size_t max_blocks = (max_frame_bytes - kChunkHeaderReserveBytes) / kMaxBlockWireBytes;
  if (map_blocks_per_chunk < 1 || map_blocks_per_chunk > max_blocks) {
    return Error{"api.map_blocks_per_chunk: " + std::to_string(map_blocks_per_chunk) + " is outside [1, " +
                 std::to_string(max_blocks) + "] for max_frame_bytes " + std::to_string(max_frame_bytes)};
  }
  const std::size_t max_points = (max_frame_bytes - kChunkHeaderReserveBytes) / kMaxPointWireBytes;
  if (cloud_points_per_chunk < 1 || cloud_points_per_chunk > max_points) {
    return Error{"api.cloud_points_per_chunk: " + std::to_string(cloud_points_per_chunk) + " is outside [1, " +
                 std::to_string(max_points) + "] for max_frame_bytes " + std::to_string(max_frame_bytes)};
  }
  if (server_name.size() > 256) return Error{"api.server_name: longer than 256 bytes"};
  return {};
}

v1::Envelope makeError(std::uint64_t request_id, v1::ErrorCode code, std::string message) {
  v1::Envelope e;
  e.set_request_id(request_id);
  e.mutable_error()->set_code(code);
  e.mutable_error()->set_message(std::move(message));
  return e;
}

Dispatcher::Dispatcher(ApiBackend& backend, NonceSource& nonces, ApiLogger* logger, DispatchConfig config)
    : backend_(backend), nonces_(nonces), logger_(logger), config_(std::move(config)) {}

void Dispatcher::log(LogLevel level, const std::string& message) const {
  if (logger_ != nullptr) logger_->log(level, message);
}

Reply Dispatcher::handle(const v1::Envelope& request, SessionState& session) {
  const std::uint64_t id = request.request_id();
  using B = v1::Envelope::BodyCase;
  const B body = request.body_case();
  const bool is_request = body == B::kHello || body == B::kChallengeResponse || body == B::kGetStatus ||
                          body == B::kSubscribe || body == B::kGetMap || body == B::kListSubmaps ||
                          body == B::kGetCloud || body == B::kMissionCommand || body == B::kGetConfig ||
                          body == B::kGetGraph || body == B::kGetSubmap;
  if (!is_request) {
    const std::string what =
        body == B::BODY_NOT_SET
            ? std::string("an envelope without a known request")
            : "a " + request.GetDescriptor()->FindFieldByNumber(static_cast<int>(body))->name() + " message";
    log(LogLevel::kWarning, session.peer + ": sent " + what + "; disconnecting");
    return errorReply(id, v1::ERROR_CODE_UNKNOWN_MESSAGE, "unknown message type: " + what + " is not a request", true);
  }
  if (id == 0) return errorReply(0, v1::ERROR_CODE_INVALID_ARGUMENT, "request_id must be non-zero");

  switch (body) {
    case B::kHello: return hello(id, request.hello(), session);
    case B::kChallengeResponse: return challenge(id, request.challenge_response(), session);
    case B::kGetStatus: {
      v1::Envelope out;
      out.set_request_id(id);
      toProto(backend_.status(), *out.mutable_status());
      return single(std::move(out));
    }
    case B::kSubscribe: {
      const auto& s = request.subscribe();
      session.subscriptions = {s.waypoints(), s.poses(), s.status(), s.graph()};
      v1::Envelope out;
      out.set_request_id(id);
      out.mutable_subscribed()->set_waypoints(s.waypoints());
      out.mutable_subscribed()->set_poses(s.poses());
      out.mutable_subscribed()->set_status(s.status());
      out.mutable_subscribed()->set_graph(s.graph());
      return single(std::move(out));
    }
    case B::kGetMap: return map(id, request.get_map());
    case B::kListSubmaps: {
      v1::Envelope out;
      out.set_request_id(id);
      auto* list = out.mutable_submap_list();
      for (const SubmapInfo& info : backend_.submaps()) toProto(info, *list->add_submaps());
      if (out.ByteSizeLong() > config_.max_frame_bytes) {
        return errorReply(id, v1::ERROR_CODE_INTERNAL, "submap list exceeds the maximum frame size");
      }
      return single(std::move(out));
    }
    case B::kGetCloud: return cloud(id, request.get_cloud());
    case B::kGetGraph: {
      const std::shared_ptr<const GraphState> graph = backend_.graph();
      if (!graph) return errorReply(id, v1::ERROR_CODE_UNAVAILABLE, "no pose graph yet (no closed submap)");
      v1::Envelope out;
      out.set_request_id(id);
      toProto(graphUpdate(nullptr, *graph), *out.mutable_graph());
      if (out.ByteSizeLong() > config_.max_frame_bytes) {
        return errorReply(id, v1::ERROR_CODE_INTERNAL, "the pose graph exceeds the maximum frame size");
      }
      return single(std::move(out));
    }
    case B::kGetSubmap: return submap(id, request.get_submap());
    case B::kMissionCommand: return command(id, request.mission_command(), session);
    case B::kGetConfig: {
      v1::Envelope out;
      out.set_request_id(id);
      out.mutable_config_text()->set_text(backend_.configText());
      if (out.ByteSizeLong() > config_.max_frame_bytes) {
        return errorReply(id, v1::ERROR_CODE_INTERNAL, "configuration text exceeds the maximum frame size");
      }
      return single(std::move(out));
    }
    default: break;
  }
  return errorReply(id, v1::ERROR_CODE_INTERNAL, "request not handled");
}

Reply Dispatcher::submap(std::uint64_t id, const v1::GetSubmap& request) {
  std::uint32_t slice = request.max_bytes_per_chunk() == 0 ? kDefaultSubmapSliceBytes : request.max_bytes_per_chunk();
  // A slice that does not compress still fits a frame: zlib adds at most about 0.1 % and 13 bytes.
  const std::uint64_t frame_room = config_.max_frame_bytes > 2 * kChunkHeaderReserveBytes
                                       ? (config_.max_frame_bytes - 2 * kChunkHeaderReserveBytes) * 999 / 1000
                                       : 0;
  const std::uint64_t max_slice = std::min<std::uint64_t>(kMaxSubmapSliceBytes, frame_room);
  if (slice > max_slice) {
    return errorReply(id, v1::ERROR_CODE_INVALID_ARGUMENT,
                      "get_submap.max_bytes_per_chunk " + std::to_string(slice) + " is above " +
                          std::to_string(max_slice) + " (the frame size allows no more)");
  }
  std::shared_ptr<const map::LocalGrid> grid = backend_.submapGrid(request.id());
  if (!grid) {
    return errorReply(id, v1::ERROR_CODE_INVALID_ARGUMENT,
                      "get_submap.id " + std::to_string(request.id()) + " is not a closed submap");
  }
  Reply r;
  r.chunks = makeSubmapChunks(id, request.id(), std::move(grid), slice);
  return r;
}

Reply Dispatcher::hello(std::uint64_t id, const v1::Hello& hello, SessionState& session) {
  if (hello.protocol_version() != kProtocolVersion) {
    return errorReply(id, v1::ERROR_CODE_INVALID_ARGUMENT,
                      "hello.protocol_version " + std::to_string(hello.protocol_version()) +
                          " is not supported (this server speaks " + std::to_string(kProtocolVersion) + ")");
  }
  v1::Envelope out;
  out.set_request_id(id);
  auto* r = out.mutable_hello_response();
  r->set_protocol_version(kProtocolVersion);
  r->set_server_name(config_.server_name);
  r->set_max_frame_bytes(config_.max_frame_bytes);
  r->set_role(toProto(session.role));
  r->set_operator_enabled(!config_.operator_secret.empty());
  if (!config_.operator_secret.empty()) {
    auto nonce = nonces_.nonce(kNonceBytes);
    if (!nonce) {
      log(LogLevel::kError, "no nonce for " + session.peer + ": " + nonce.error().message);
      return errorReply(id, v1::ERROR_CODE_INTERNAL, "no challenge available: " + nonce.error().message);
    }
    session.pending_server_nonce = std::move(*nonce);
    r->set_server_nonce(session.pending_server_nonce);
  }
  return single(std::move(out));
}

Reply Dispatcher::challenge(std::uint64_t id, const v1::ChallengeResponse& response, SessionState& session) {
  if (config_.operator_secret.empty()) {
    log(LogLevel::kWarning, session.peer + ": authentication attempt refused: the operator role is disabled");
    return errorReply(id, v1::ERROR_CODE_AUTH_FAILED, "the operator role is disabled on this server");
  }
  if (session.pending_server_nonce.empty()) {
    log(LogLevel::kWarning, session.peer + ": authentication refused: no challenge pending");
    return errorReply(id, v1::ERROR_CODE_AUTH_FAILED, "no challenge pending: send Hello first");
  }
  // A nonce answers one attempt only: a failed guess needs a new Hello and a new nonce.
  const std::string server_nonce = std::move(session.pending_server_nonce);
  session.pending_server_nonce.clear();
  if (response.client_nonce().size() != kNonceBytes || response.mac().size() != kMacBytes) {
    log(LogLevel::kWarning, session.peer + ": authentication refused: bad nonce or MAC length");
    return errorReply(id, v1::ERROR_CODE_AUTH_FAILED,
                      "challenge_response.client_nonce must be 32 bytes and mac 32 bytes (got " +
                          std::to_string(response.client_nonce().size()) + " and " +
                          std::to_string(response.mac().size()) + ")");
  }
  const Mac expected = clientMac(config_.operator_secret, server_nonce, response.client_nonce());
  if (!macEquals(response.mac(), expected)) {
    log(LogLevel::kWarning, session.peer + ": authentication failed: wrong MAC (wrong secret?)");
    return errorReply(id, v1::ERROR_CODE_AUTH_FAILED, "authentication failed");
  }
  session.role = Role::kOperator;
  log(LogLevel::kInfo, session.peer + ": authenticated as operator");
  v1::Envelope out;
  out.set_request_id(id);
  out.mutable_auth_result()->set_role(v1::ROLE_OPERATOR);
  const Mac proof = serverProof(config_.operator_secret, server_nonce, response.client_nonce());
  out.mutable_auth_result()->set_server_proof(std::string(asBytes(proof)));
  return single(std::move(out));
}

Reply Dispatcher::map(std::uint64_t id, const v1::GetMap& request) {
  const std::shared_ptr<const map::MergedMap> snapshot = backend_.mapSnapshot();
  if (!snapshot) return errorReply(id, v1::ERROR_CODE_UNAVAILABLE, "no map yet");
  if (request.since_version() > snapshot->version()) {
    return errorReply(id, v1::ERROR_CODE_INVALID_ARGUMENT,
                      "get_map.since_version " + std::to_string(request.since_version()) +
                          " is newer than the map's version " + std::to_string(snapshot->version()) +
                          " (the daemon restarted? fetch from 0)");
  }
  const std::size_t max_blocks = (config_.max_frame_bytes - kChunkHeaderReserveBytes) / kMaxBlockWireBytes;
  std::size_t per_chunk =
      request.max_blocks_per_chunk() == 0 ? config_.map_blocks_per_chunk : request.max_blocks_per_chunk();
  per_chunk = std::clamp<std::size_t>(per_chunk, 1, max_blocks);
  Reply r;
  r.chunks = std::make_unique<MapChunks>(id, snapshot, request.since_version(), per_chunk);
  return r;
}

Reply Dispatcher::cloud(std::uint64_t id, const v1::GetCloud& request) {
  std::shared_ptr<const ServedCloud> cloud = backend_.cloud();
  if (!cloud) {
    return errorReply(id, v1::ERROR_CODE_UNAVAILABLE,
                      "no reconstruction yet (the first one is built once asked for: ask again in a moment)");
  }
  const std::size_t max_points = (config_.max_frame_bytes - kChunkHeaderReserveBytes) / kMaxPointWireBytes;
  std::size_t per_chunk =
      request.max_points_per_chunk() == 0 ? config_.cloud_points_per_chunk : request.max_points_per_chunk();
  per_chunk = std::clamp<std::size_t>(per_chunk, 1, max_points);
  Reply r;
  r.chunks = std::make_unique<CloudChunks>(id, std::move(cloud), per_chunk);
  return r;
}

Reply Dispatcher::command(std::uint64_t id, const v1::MissionCommand& request, SessionState& session) {
  if (session.role != Role::kOperator) {
    log(LogLevel::kWarning, session.peer + ": refused mission command " +
                                v1::MissionCommand::Kind_Name(request.kind()) + ": not authenticated as operator");
    return errorReply(id, v1::ERROR_CODE_UNAUTHENTICATED,
                      "mission commands need the operator role: authenticate first");
  }
  auto command = fromProto(request);
  if (!command) return errorReply(id, v1::ERROR_CODE_INVALID_ARGUMENT, command.error().message);
  auto state = backend_.command(*command);
  if (!state) {
    log(LogLevel::kInfo,
        session.peer + ": mission command " + toString(command->kind) + " rejected: " + state.error().message);
    return errorReply(id, v1::ERROR_CODE_REJECTED, state.error().message);
  }
  log(LogLevel::kInfo,
      session.peer + ": mission command " + toString(command->kind) + " accepted, mission " + toString(*state));
  v1::Envelope out;
  out.set_request_id(id);
  out.mutable_command_result()->set_mission_state(toProto(*state));
  return single(std::move(out));
}

}  // namespace vog::api
