#pragma once
// Request handling of vogd's API without sockets: one decoded request Envelope in, the reply out.
// ApiServer runs it for every session; the fuzz target runs it directly on decoded frames.

#include "vog/api/auth.hpp"
#include "vog/api/domain.hpp"
#include "vog/v1/api.pb.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace vog::api {

inline constexpr std::uint32_t kProtocolVersion = 1;
// Serialized size bounds of one map block (64 known + 2048 value bytes + origin, version, tags) and of
// one cloud point (6 float32), used to keep every chunk under the maximum frame size.
inline constexpr std::size_t kMaxBlockWireBytes = 2200;
inline constexpr std::size_t kMaxPointWireBytes = 6 * sizeof(float);
inline constexpr std::size_t kChunkHeaderReserveBytes = 1024;

struct DispatchConfig {
  std::string server_name = "vogd";
  std::string operator_secret;               // empty: the operator role is disabled
  std::uint32_t max_frame_bytes = 4u << 20;  // every frame the server sends stays below this too
  std::uint32_t map_blocks_per_chunk = 256;  // default when GetMap does not choose (about 0.5 MB)
  std::uint32_t cloud_points_per_chunk = 32768;

  // Names the first bad key and value.
  Status validate() const;
};

// What one connection has established. Owned by its session, changed only by Dispatcher::handle.
struct SessionState {
  std::string peer;  // "address:port", for logs
  Role role = Role::kObserver;
  std::string pending_server_nonce;  // set by Hello, consumed by the next ChallengeResponse
  Subscriptions subscriptions;
};

// The later frames of a chunked reply (map, cloud), produced one at a time as the connection drains,
// so a slow reader paces the transfer and no transfer is ever held as frames in memory.
class ChunkSource {
 public:
  virtual ~ChunkSource() = default;
  virtual bool done() const = 0;
  virtual v1::Envelope next() = 0;
  virtual std::uint64_t requestId() const = 0;
};

struct Reply {
  std::vector<v1::Envelope> frames;     // sent first, in order
  std::unique_ptr<ChunkSource> chunks;  // then these
  bool disconnect = false;              // close after sending `frames` (protocol violation)
};

v1::Envelope makeError(std::uint64_t request_id, v1::ErrorCode code, std::string message);

// Stateless apart from the nonce source; every call reads the backend afresh.
class Dispatcher {
 public:
  // `logger` may be null. The references must outlive the dispatcher.
  Dispatcher(ApiBackend& backend, NonceSource& nonces, ApiLogger* logger, DispatchConfig config);

  Reply handle(const v1::Envelope& request, SessionState& session);
  const DispatchConfig& config() const { return config_; }

 private:
  Reply hello(std::uint64_t id, const v1::Hello& hello, SessionState& session);
  Reply challenge(std::uint64_t id, const v1::ChallengeResponse& response, SessionState& session);
  Reply map(std::uint64_t id, const v1::GetMap& request);
  Reply cloud(std::uint64_t id, const v1::GetCloud& request);
  Reply submap(std::uint64_t id, const v1::GetSubmap& request);
  Reply command(std::uint64_t id, const v1::MissionCommand& request, SessionState& session);
  void log(LogLevel level, const std::string& message) const;

  ApiBackend& backend_;
  NonceSource& nonces_;
  ApiLogger* logger_;
  DispatchConfig config_;
};

}  // namespace vog::api
