#pragma once
// vog-console's web server: HTTP/1.1 (the page's static files, GET /api/state) and WebSocket
// sessions (GET /ws) on one thread of its own running a boost::asio::io_context (Boost.Beast).
// It moves bytes only: what the JSON says is the console's business (README.md, "The page's protocol").
//
// Threads and ownership:
//  - the web thread (started by start(), joined by stop()) runs every accept, session, timer and
//    callback. It alone owns the sessions, their outbound queues and the connection counts;
//  - sendText/sendBinary/broadcastText/close/stop may be called from any thread: they post to the
//    web thread and never wait for a client;
//  - stats() reads counters the web thread keeps as atomics.
//
// Security (the page can command the vehicle):
//  - with a token configured, every HTTP request and every WebSocket upgrade carries it (query
//    `token=` or cookie `vog_token`, compared in constant time), else 401. GET / or /index.html with
//    the right query token sets the cookie (HttpOnly, SameSite=Strict) so the page's later requests pass;
//  - a WebSocket upgrade whose Origin names another host:port than its Host is refused (403): a page
//    of another site must not drive the vehicle through the operator's browser. No Origin (a
//    non-browser client) is allowed;
//  - static files are regular files under web_root only: a target whose decoded path has a `..`
//    segment, a backslash or a NUL, or whose real path (symlinks resolved) leaves web_root, is 404.
//
// Per-client limits (a client can only hurt itself):
//  - WebSocket frames to a client are queued in order and written one at a time. A client whose
//    unsent bytes would exceed max_queued_bytes, or whose pending write (or close handshake) does not
//    complete within write_timeout, is closed and counted as slow_closed;
//  - a page message over max_message_bytes fails the WebSocket with close code 1009 (Beast sends it);
//    a binary message gets an `error` message and the socket stays open;
//  - beyond max_clients connections (HTTP and WebSocket together) a new connection is answered 503
//    and closed; an HTTP connection idle for idle_timeout is closed, and so is a WebSocket that sends
//    nothing for idle_timeout (the server pings it at half of that; browsers answer pings by themselves).

#include "vog/core/result.hpp"

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace vog::console {

// A WebSocket client: 1, 2, ... in order of completed handshakes; never reused.
using ClientId = std::uint64_t;

struct WebServerConfig {
  std::string address = "127.0.0.1";
  std::uint16_t port = 8080;                       // 0 picks a free port
  std::filesystem::path web_root;                  // static files served under /; empty: none (404)
  std::string token;                               // non-empty: required on every request; letters, digits, -._~
  std::size_t max_message_bytes = 64 * 1024;       // page -> server message limit (README: 64 KiB)
  std::size_t max_queued_bytes = 64u << 20;        // per WebSocket client: unsent bytes; beyond, the client is closed
  std::size_t max_clients = 32;                    // WebSocket + HTTP connections; beyond, new ones get 503 and close
  std::chrono::milliseconds write_timeout{10000};  // a write (or close handshake) that takes longer: closed
  std::chrono::milliseconds idle_timeout{60000};   // HTTP without a request, WebSocket without a byte: closed

  // Names the first bad field and its value (never the token's value).
  Status validate() const;
};

// Called on the web thread, never concurrently; any may be empty. They must not throw (state_json
// may: its exception answers 500) and must not call stop().
struct WebServerCallbacks {
  std::function<void(ClientId)> opened;                  // a WebSocket completed its handshake
  std::function<void(ClientId, std::string text)> text;  // a text message from the page
  std::function<void(ClientId)> closed;                  // once per opened client, stop() included
  std::function<std::string()> state_json;               // body of GET /api/state (application/json)
};

struct WebServerStats {
  std::uint64_t http_requests = 0;      // requests parsed, upgrades and refusals included
  std::uint64_t ws_clients = 0;         // WebSockets open now
  std::uint64_t ws_opened = 0;          // handshakes completed since start
  std::uint64_t refused_token = 0;      // 401: token missing or wrong
  std::uint64_t refused_origin = 0;     // 403: upgrade from another origin
  std::uint64_t oversize_messages = 0;  // page messages over max_message_bytes (closed with 1009)
  std::uint64_t binary_refused = 0;     // binary page messages answered with an error
  std::uint64_t slow_closed = 0;        // clients closed for max_queued_bytes or write_timeout
  std::uint64_t queued_bytes = 0;       // unsent WebSocket bytes of all clients now
  std::uint64_t refused_full = 0;       // connections answered 503 (max_clients reached)
};

// Lifecycle: start() binds, listens and starts the web thread; stop() (or the destructor) closes
// every connection, calls `closed` for each open WebSocket and joins the thread. After stop() the
// send functions do nothing.
class WebServer {
 public:
  static Result<std::unique_ptr<WebServer>> start(WebServerConfig config, WebServerCallbacks callbacks);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  std::uint16_t port() const;  // the bound port

  // Thread-safe; never block: post to the web thread. Unknown or closed id: ignored.
  void sendText(ClientId id, std::string text);
  void sendBinary(ClientId id, std::string bytes);
  void broadcastText(std::string text);  // to every open WebSocket
  // Queues a close frame (code 1000, normal; reason cut to the protocol's 123 bytes) after the frames
  // already queued; nothing queued later is sent.
  void close(ClientId id, std::string reason);
  // Closes everything and joins the web thread; idempotent. Not from a callback.
  void stop();

  WebServerStats stats() const;

  // The web thread's state (defined in the source).
  struct Core;

 private:
  explicit WebServer(std::unique_ptr<Core> core);

  std::unique_ptr<Core> core_;  // owned here; its mutable parts by the web thread (see Core)
  std::mutex stop_mutex_;       // serialises stop(); guards thread_
  std::thread thread_;          // runs core_'s io_context; guarded by stop_mutex_ once started
};

}  // namespace vog::console
