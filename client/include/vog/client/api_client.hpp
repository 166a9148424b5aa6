#pragma once
// Blocking client of vogd's API (proto/README.md): connect, authenticate as operator, call with
// request ids, receive stream messages, follow the merged map into a MapMirror.

#include "vog/api/domain.hpp"
#include "vog/api/graph.hpp"
#include "vog/api/map_delta.hpp"
#include "vog/core/result.hpp"
#include "vog/v1/api.pb.h"

#include <chrono>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <variant>

namespace vog::client {

// TLS to a server configured with api.tls: the server's certificate is verified against `ca_file`
// (PEM; empty: the system's trusted CAs) and must name the host connected to.
struct ClientTlsConfig {
  bool enabled = false;
  std::filesystem::path ca_file;
};

struct ClientConfig {
  std::string client_name = "vogctl";
  ClientTlsConfig tls;
  std::uint32_t max_frame_bytes = 64u << 20;  // largest frame accepted from the server
  std::chrono::milliseconds timeout{10000};   // per call: connect, each request, each frame of a transfer
  std::size_t max_buffered_streams = 4096;    // stream messages kept while waiting for a response
  int socket_receive_buffer_bytes = 0;        // SO_RCVBUF (a slow tether's window); 0 keeps the OS default

  Status validate() const;
};

struct ServerInfo {
  std::uint32_t protocol_version = 0;
  std::string server_name;
  std::uint32_t max_frame_bytes = 0;
  api::Role role = api::Role::kObserver;
  bool operator_enabled = false;
};

using StreamMessage = std::variant<api::Waypoint, api::PoseUpdate, api::StatusUpdate, api::GraphUpdate>;

// Progress of a chunked transfer: items (blocks or points) received so far and in total.
using ProgressFn = std::function<void(std::uint64_t received, std::uint64_t total)>;

// A server Error frame, with its code.
struct ServerError {
  v1::ErrorCode code = v1::ERROR_CODE_UNSPECIFIED;
  std::string message;
};

// One TCP (or TLS over TCP) connection to vogd.
// Lifecycle: connect() -> calls (each blocks until its response, an error frame, or the timeout) ->
// destroy. Stream messages arriving meanwhile are buffered (oldest dropped beyond
// max_buffered_streams) and returned by nextStream(). After a transport or framing error the
// connection is broken: every later call fails. Not thread-safe: one thread uses a client.
class ApiClient {
 public:
  static Result<std::unique_ptr<ApiClient>> connect(const std::string& host, std::uint16_t port,
                                                    ClientConfig config = {});
  ~ApiClient();
  ApiClient(const ApiClient&) = delete;
  ApiClient& operator=(const ApiClient&) = delete;

  Result<ServerInfo> hello();
  // Hello + challenge-response with the shared secret; checks the server's proof too.
  // `client_nonce` empty draws 32 random bytes (RAND_bytes); tests pass a fixed one.
  Result<api::Role> authenticate(std::string_view secret, std::string_view client_nonce = {});
  Result<api::StatusReport> status();
  Result<api::Subscriptions> subscribe(const api::Subscriptions& subscriptions);
  Result<std::vector<api::SubmapInfo>> submaps();
  // GetGraph: the whole pose graph (a full update; UNAVAILABLE before the first closed submap).
  Result<api::GraphUpdate> graph();
  // GetSubmap: a closed submap's grid, every chunk checked (length, CRC-32) and the tree rebuilt.
  Result<std::unique_ptr<map::LocalGrid>> fetchSubmap(std::uint32_t id, std::uint32_t max_bytes_per_chunk = 0);
  // The reconstruction; asks again for up to 5 s while the server answers UNAVAILABLE (vogd builds
  // one only once asked for).
  Result<api::Cloud> cloud(const ProgressFn& progress = {});
  Result<api::MissionState> command(const api::MissionCommand& command);
  Result<std::string> configText();
  // Brings `mirror` to the server's newest map: GetMap(since = mirror.version()), all chunks
  // gathered, then applied at once (the mirror is unchanged when anything fails).
  Status fetchMap(api::MapMirror& mirror, const ProgressFn& progress = {}, std::uint32_t max_blocks_per_chunk = 0);

  // The next stream message (buffered first), or an error after `timeout` (timedOut() says which).
  Result<StreamMessage> nextStream(std::chrono::milliseconds timeout);
  // The last receive() or nextStream() failed only because nothing arrived in time.
  bool timedOut() const { return timed_out_; }
  std::size_t droppedStreams() const { return dropped_streams_; }
  // Bytes read from the connection so far (TLS: the decrypted bytes), for link budgets.
  std::uint64_t bytesReceived() const { return bytes_received_; }

  // The last Error frame the server sent (for callers that need its code).
  const ServerError& lastServerError() const { return last_server_error_; }

  // Low level, for tests and tools: send an Envelope (a request id is assigned when it has none)
  // or raw bytes; receive the next frame of any kind.
  Result<std::uint64_t> send(v1::Envelope envelope);
  Status sendRaw(std::string_view bytes);
  Result<v1::Envelope> receive(std::chrono::milliseconds timeout);
  bool broken() const { return broken_; }

  struct Impl;

 private:
  Result<api::Cloud> cloudOnce(const ProgressFn& progress);
  ApiClient(std::unique_ptr<Impl> impl, ClientConfig config);
  // Sends `request` and returns the response with its id, buffering stream messages meanwhile.
  // An Error frame for this id (or id 0) becomes an Error naming its code.
  Result<v1::Envelope> call(v1::Envelope request);
  Result<v1::Envelope> awaitResponse(std::uint64_t id);
  // A chunked transfer (GetMap, GetCloud): sends `request` and hands each chunk of type `chunk_body`
  // to `take` in order, checking the sequence (indices 0 .. count-1, one count). `what` names the
  // transfer in errors; an error from `take` ends the transfer with that error.
  Status receiveChunks(v1::Envelope request, const char* what, v1::Envelope::BodyCase chunk_body,
                       const std::function<Status(v1::Envelope&, std::uint32_t index)>& take);
  Error fail(std::string message);

  std::unique_ptr<Impl> impl_;
  ClientConfig config_;
  std::uint64_t next_id_ = 1;
  std::deque<v1::Envelope> streams_;
  std::size_t dropped_streams_ = 0;
  std::uint64_t bytes_received_ = 0;
  bool timed_out_ = false;
  ServerError last_server_error_;
  bool broken_ = false;
};

// A server Error frame as an Error ("ERROR_CODE_X: message").
Error toError(const v1::Error& error);

}  // namespace vog::client
