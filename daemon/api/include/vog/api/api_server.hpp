#pragma once
// vogd's API server: TCP sessions on the daemon's I/O io_context (DESIGN "Threads in vogd"), framing
// (vog/api/framing.hpp), requests answered by a Dispatcher over an ApiBackend, and server-pushed
// streams (waypoints, poses, status, the pose graph) that other threads publish.
//
// Per-client outbound queue (the rule that keeps a slow topside from stalling the vehicle):
//  - responses are never dropped. While a client's unsent responses number `max_queued_responses`
//    or leave less than one maximum frame of its `max_queued_bytes`, its requests are not decoded
//    (nor more bytes read): they wait in the socket until the replies drain (TCP flow control), and
//    every request decoded gets exactly one reply (or its transfer);
//  - waypoints queue up to `max_queued_waypoints`, then the oldest is dropped and counted; poses and
//    status are coalesced (a newer one replaces an unsent one, counted);
//  - map and cloud transfers are encoded chunk by chunk from the held immutable snapshot as the
//    socket drains, one transfer at a time, and only while a maximum frame still fits in the
//    client's `max_queued_bytes` (responses and the batch being written count); later transfers
//    wait as a snapshot pointer. So a client's queued bytes never exceed `max_queued_bytes`, apart
//    from the one Error frame that precedes a disconnect;
//  - a socket that accepts no byte for `write_timeout` while the server has data for it is closed
//    (a reader that never reads), counted as a slow disconnect.
// Connection slots (`max_clients`, `max_clients_per_peer` per peer address): a session must complete
// a request within `hello_timeout` of connecting (the TLS handshake included) and is closed after
// `idle_timeout` without a request, unless it is subscribed to a stream or still being answered.
// When the server or the peer's share is full, a new connection takes the slot of the most idle
// unauthenticated session (of that peer when the peer's share is full): first those that never
// completed a request (oldest first), then those with nothing subscribed or pending (longest since
// their last request first), then the rest. The evicted session gets TOO_MANY_CLIENTS and is closed.
// Eviction rather than a slot reserved for authentication, because an operator's plain `vogctl
// status` needs no authentication and must still get in, and because a reserved slot can itself be
// held by a hostile client for hello_timeout again and again. Authenticated operator sessions are
// never evicted; when every candidate is one, the new connection is refused with TOO_MANY_CLIENTS.
// Failed authentications are counted per peer address: after 3, each further attempt waits (1 s,
// doubling to 30 s); an attempt during the wait is refused (RATE_LIMITED, naming the wait) and logged.
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
  std::size_t max_in_flight = 16;                  // requests whose replies are not yet handed to the socket
  double max_requests_per_s = 200.0;               // token bucket refill rate per client
  double request_burst = 400.0;                    // token bucket size per client
  std::size_t max_queued_responses = 256;          // unsent response frames per client; then its requests wait
  std::size_t max_queued_waypoints = 64;           // per client; the oldest is dropped beyond
  int socket_send_buffer_bytes = 0;                // SO_SNDBUF of client sockets; 0 keeps the OS default
  std::chrono::milliseconds close_timeout{1000};   // a closing client gets this long to read its error
  std::size_t max_clients_per_peer = 16;           // sessions from one peer address
  std::chrono::milliseconds hello_timeout{5000};   // from connect to the first complete request
  std::chrono::milliseconds idle_timeout{300000};  // without a request, unless subscribed or being answered
  std::size_t max_queued_bytes = 8u << 20;         // per client: unsent responses + the batch being written
  std::chrono::milliseconds write_timeout{10000};  // without write progress while data waits: disconnect

  // Names the first bad key and value.
  Status validate() const;
};

struct ApiServerStats {
  std::uint64_t clients = 0;  // connected now
  std::uint64_t accepted = 0;
  std::uint64_t refused_full = 0;      // refused: full, and no session could be evicted
  std::uint64_t protocol_errors = 0;   // disconnects for malformed/oversize/unknown frames
  std::uint64_t tls_failures = 0;      // TLS handshakes that failed or timed out
  std::uint64_t slow_disconnects = 0;  // disconnects for no write progress in write_timeout
  std::uint64_t stream_drops = 0;      // stream messages dropped or coalesced, all clients
  std::uint64_t waypoint_drops = 0;    // of which waypoints (poses and status are coalesced)
  std::uint64_t waypoints_published = 0;
  std::uint64_t requests = 0;
  std::uint64_t evicted = 0;                   // sessions closed to make room for a new connection
  std::uint64_t hello_timeouts = 0;            // closed: no complete request within hello_timeout
  std::uint64_t idle_timeouts = 0;             // closed: no request within idle_timeout
  std::uint64_t auth_failures = 0;             // failed authentication attempts
  std::uint64_t auth_throttled = 0;            // attempts refused while their peer address had to wait
  std::uint64_t queued_bytes = 0;              // unsent response and batch bytes of all clients now
  std::uint64_t max_session_queued_bytes = 0;  // the most any one client had queued, since start
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
  // The backend's graph() changed: every session subscribed to the graph gets what it lacks.
  void publishGraph();
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
