#pragma once
// vogd's API server: TCP sessions on the daemon's I/O io_context (DESIGN "Threads in vogd"), framing
// (vog/api/framing.hpp), requests answered by a Dispatcher over an ApiBackend, and server-pushed
// streams (waypoints, poses, status) that other threads publish.
//
// Per-client outbound queue (the rule that keeps a slow topside from stalling the vehicle):
//  - responses are never dropped; a client with more than `max_queued_responses` unsent response
//    frames cannot keep up and is disconnected;
//  - waypoints queue up to `max_queued_waypoints`, then the oldest is dropped and counted; poses and
//    status are coalesced (a newer one replaces an unsent one, counted);
//  - map and cloud transfers are produced chunk by chunk as the socket drains.
// Protocol violations (malformed frame, oversize length, unknown message type) get an Error frame,
// then that client alone is disconnected. With TLS configured every session starts with a TLS
// handshake; a client that fails it (plain TCP, a bad certificate) is closed and counted.

#include "vog/api/auth.hpp"
#include "vog/api/dispatcher.hpp"
#include "vog/api/domain.hpp"

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

namespace asio {
class io_context;
}

namespace vog::api {

// TLS (asio::ssl, TLS 1.2 and newer) for every client: the server's certificate chain and key, PEM.
// Clients verify the server against their CA file; authentication of operators is unchanged
// (HMAC challenge-response inside the encrypted channel).
struct TlsServerConfig {
  std::filesystem::path certificate_chain_file;
  std::filesystem::path private_key_file;
  std::chrono::milliseconds handshake_timeout{5000};  // a client that does not finish is closed
  bool enabled() const { return !certificate_chain_file.empty(); }
};

struct ApiServerConfig {
  DispatchConfig dispatch;
  TlsServerConfig tls;  // disabled when no certificate is given
  std::size_t max_clients = 64;
  std::size_t max_in_flight = 16;                 // requests whose replies are not yet handed to the socket
  double max_requests_per_s = 200.0;              // token bucket refill rate per client
  double request_burst = 400.0;                   // token bucket size per client
  std::size_t max_queued_responses = 256;         // unsent response frames per client before a disconnect
  std::size_t max_queued_waypoints = 64;          // per client; the oldest is dropped beyond
  int socket_send_buffer_bytes = 0;               // SO_SNDBUF of client sockets; 0 keeps the OS default
  std::chrono::milliseconds close_timeout{1000};  // a closing client gets this long to read its error

  // Names the first bad key and value.
  Status validate() const;
};

struct ApiServerStats {
  std::uint64_t clients = 0;  // connected now
  std::uint64_t accepted = 0;
  std::uint64_t refused_full = 0;      // refused: max_clients reached
  std::uint64_t protocol_errors = 0;   // disconnects for malformed/oversize/unknown frames
  std::uint64_t tls_failures = 0;      // TLS handshakes that failed or timed out
  std::uint64_t slow_disconnects = 0;  // disconnects for unread responses
  std::uint64_t stream_drops = 0;      // stream messages dropped or coalesced, all clients
  std::uint64_t waypoint_drops = 0;    // of which waypoints (poses and status are coalesced)
  std::uint64_t waypoints_published = 0;
  std::uint64_t requests = 0;
};

// Lifecycle: construct, listen(), run the io_context (one thread), publish*() from any thread,
// stop() from any thread; destroy after the io_context has stopped running. Every session and
// handler lives on the io_context thread; publish*() and stop() only post to it. The backend
// must outlive the io_context's run.
class ApiServer {
 public:
  // `logger` may be null; `nonces` null means SystemNonceSource (RAND_bytes).
  static Result<std::unique_ptr<ApiServer>> create(asio::io_context& io, ApiBackend& backend, ApiServerConfig config,
                                                   ApiLogger* logger = nullptr,
                                                   std::unique_ptr<NonceSource> nonces = nullptr);
  ~ApiServer();
  ApiServer(const ApiServer&) = delete;
  ApiServer& operator=(const ApiServer&) = delete;

  // Binds, listens and starts accepting; returns the bound port (port 0 picks a free one). Call
  // before the io_context runs or on its thread.
  Result<std::uint16_t> listen(const std::string& address, std::uint16_t port);

  // Thread-safe; never blocks on a client. The seq of a waypoint is assigned here (1, 2, ...).
  void publishWaypoint(const Waypoint& waypoint);
  void publishPose(const PoseUpdate& pose);
  void publishStatus(const StatusReport& status);
  // Thread-safe: stops accepting and closes every session.
  void stop();

  ApiServerStats stats() const;

  // The shared state of the io thread, and one client connection (both defined in the source).
  struct Core;
  class Session;

 private:
  explicit ApiServer(std::shared_ptr<Core> core);
  std::shared_ptr<Core> core_;
};

}  // namespace vog::api
