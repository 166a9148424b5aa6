#include "vog/api/api_server.hpp"

#include "vog/api/convert.hpp"
#include "vog/api/framing.hpp"

#include <asio.hpp>
#include <asio/ssl.hpp>

#include <atomic>
#include <deque>
#include <optional>
#include <unordered_map>

namespace vog::api {

namespace {

using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

// Frames are gathered into one write of up to this many bytes (fewer syscalls for many small
// stream messages; one map chunk per write).
constexpr std::size_t kWriteBatchBytes = 256 * 1024;
constexpr std::size_t kReadChunkBytes = 64 * 1024;

}  // namespace

using Session = ApiServer::Session;

struct ApiServer::Core : std::enable_shared_from_this<ApiServer::Core> {
  Core(asio::io_context& io_in, ApiBackend& backend, ApiServerConfig config_in, ApiLogger* logger_in,
       std::unique_ptr<NonceSource> nonces_in, std::unique_ptr<asio::ssl::context> tls_in)
      : io(io_in),
        config(std::move(config_in)),
        logger(logger_in),
        nonces(std::move(nonces_in)),
        tls(std::move(tls_in)),
        dispatcher(backend, *nonces, logger_in, config.dispatch),
        acceptor(io_in) {}

  void log(LogLevel level, const std::string& message) const {
    if (logger != nullptr) logger->log(level, message);
  }
  void accept();
  void closeAll();
  std::size_t activeClients() const;
  // A copy: a session may leave `sessions` while the caller walks the list.
  std::vector<std::shared_ptr<Session>> sessionList() const;

  asio::io_context& io;
  const ApiServerConfig config;
  ApiLogger* logger;
  std::unique_ptr<NonceSource> nonces;
  std::unique_ptr<asio::ssl::context> tls;  // null: plain TCP
  Dispatcher dispatcher;
  tcp::acceptor acceptor;
  bool stopped = false;               // io thread only
  std::uint64_t next_session_id = 1;  // io thread only
  // Open sessions, for broadcasts. A session is owned by its pending asynchronous operations (each
  // handler holds a shared_ptr), never by this map: a session holds the Core, so owning it here
  // would be a cycle that outlives an io_context stopped with sessions open.
  std::unordered_map<std::uint64_t, std::weak_ptr<Session>> sessions;  // io thread only

  std::atomic<std::uint64_t> waypoint_seq{0};
  std::atomic<std::uint64_t> pose_seq{0};
  std::atomic<std::uint64_t> status_seq{0};
  // Counters read by stats() from any thread.
  std::atomic<std::uint64_t> n_clients{0}, n_accepted{0}, n_refused{0}, n_protocol_errors{0}, n_slow{0}, n_drops{0},
      n_waypoint_drops{0}, n_waypoints{0}, n_requests{0}, n_tls_failures{0};
};

// One client connection.
// Lifecycle: [handshaking (TLS only; at most tls.handshake_timeout)] -> open (reading requests,
// writing replies and streams) -> closing (an Error is queued;
// no more reads; only queued responses are flushed, for at most close_timeout) -> closed (socket
// closed, removed from Core::sessions). Invariants: at most one async write and one async read in
// flight; queues are bounded as the server header describes. io thread only.
class ApiServer::Session : public std::enable_shared_from_this<ApiServer::Session> {
 public:
  Session(std::shared_ptr<ApiServer::Core> core, tcp::socket socket, std::uint64_t id, bool refuse)
      : core_(std::move(core)),
        socket_(std::move(socket)),
        close_timer_(core_->io),
        id_(id),
        refused_(refuse),
        decoder_(core_->config.dispatch.max_frame_bytes),
        tokens_(core_->config.request_burst),
        last_refill_(Clock::now()) {
    asio::error_code ec;
    const auto ep = socket_.remote_endpoint(ec);
    state_.peer = ec ? std::string("unknown peer") : ep.address().to_string() + ":" + std::to_string(ep.port());
    if (core_->tls) tls_.emplace(socket_, *core_->tls);
  }

  // Destroyed without closeNow() only when the io_context is destroyed with this session's
  // operations pending: leave the server's books right.
  ~Session() { forget(); }

  bool refused() const { return refused_; }
  const std::string& peer() const { return state_.peer; }

  void start() {
    if (!tls_) {
      begin();
      return;
    }
    close_timer_.expires_after(core_->config.tls.handshake_timeout);
    close_timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
      if (ec || self->handshake_done_) return;
      ++self->core_->n_tls_failures;
      self->core_->log(LogLevel::kWarning, self->state_.peer + ": TLS handshake timed out; disconnecting");
      self->closeNow();
    });
    tls_->async_handshake(asio::ssl::stream_base::server, [self = shared_from_this()](const asio::error_code& ec) {
      if (self->closed_) return;
      self->handshake_done_ = true;
      self->close_timer_.cancel();
      if (ec) {
        ++self->core_->n_tls_failures;
        self->core_->log(LogLevel::kWarning,
                         self->state_.peer + ": TLS handshake failed: " + ec.message() + "; disconnecting");
        self->closeNow();
        return;
      }
      self->begin();
    });
  }

  void pushWaypoint(const Waypoint& w) {
    if (closing_ || !state_.subscriptions.waypoints) return;
    if (waypoints_.size() >= core_->config.max_queued_waypoints) {
      waypoints_.pop_front();
      ++dropped_waypoints_;
      ++core_->n_drops;
      ++core_->n_waypoint_drops;
    }
    waypoints_.push_back(w);
    pump();
  }

  void pushPose(const PoseUpdate& p) {
    if (closing_ || !state_.subscriptions.poses) return;
    if (pose_) {
      ++dropped_poses_;
      ++core_->n_drops;
    }
    pose_ = p;
    pump();
  }

  void pushStatus(const StatusUpdate& s) {
    if (closing_ || !state_.subscriptions.status) return;
    if (status_) {
      ++dropped_status_;
      ++core_->n_drops;
    }
    status_ = s;
    pump();
  }

  // Immediate close, nothing more is sent.
  void closeNow() {
    if (closed_) return;
    closed_ = true;
    asio::error_code ec;
    close_timer_.cancel();
    socket_.shutdown(tcp::socket::shutdown_both, ec);
    socket_.close(ec);
    forget();
  }

 private:
  // The session proper, after the TLS handshake if there is one.
  void begin() {
    if (refused_) {
      queueResponse(makeError(0, v1::ERROR_CODE_TOO_MANY_CLIENTS,
                              "the server has " + std::to_string(core_->config.max_clients) + " clients already"));
      beginClose();
      return;
    }
    read();
  }

  // The byte stream: the TLS stream over the socket, or the socket itself.
  template <class F>
  void withStream(F&& f) {
    if (tls_) {
      f(*tls_);
    } else {
      f(socket_);
    }
  }

  void read() {
    if (closing_ || closed_) return;
    withStream([this](auto& stream) {
      stream.async_read_some(
          asio::buffer(read_buf_),
          [self = shared_from_this()](const asio::error_code& ec, std::size_t n) { self->onRead(ec, n); });
    });
  }

  void onRead(const asio::error_code& ec, std::size_t n) {
    if (closed_) return;
    if (ec) {
      if (ec != asio::error::eof && ec != asio::error::operation_aborted) {
        core_->log(LogLevel::kInfo, state_.peer + ": read failed: " + ec.message());
      }
      core_->log(LogLevel::kDebug, state_.peer + ": disconnected");
      closeNow();
      return;
    }
    decoder_.feed(std::span<const std::uint8_t>(read_buf_.data(), n));
    while (!closing_ && !closed_) {
      FrameResult r = decoder_.next();
      if (std::holds_alternative<FrameNeedMore>(r)) break;
      if (const auto* err = std::get_if<FrameError>(&r)) {
        ++core_->n_protocol_errors;
        core_->log(LogLevel::kWarning, state_.peer + ": " + err->message + "; disconnecting");
        queueResponse(makeError(
            0,
            err->kind == FrameError::Kind::kTooLarge ? v1::ERROR_CODE_FRAME_TOO_LARGE : v1::ERROR_CODE_MALFORMED_FRAME,
            err->message));
        beginClose();
        return;
      }
      handle(std::get<v1::Envelope>(r));
    }
    if (closed_) return;
    read();
    pump();
  }

  void forget() {
    if (forgotten_) return;
    forgotten_ = true;
    core_->sessions.erase(id_);
    if (!refused_) --core_->n_clients;
  }

  std::size_t inFlight() const { return responses_.size() + transfers_.size(); }

  void handle(const v1::Envelope& request) {
    ++core_->n_requests;
    const std::uint64_t id = request.request_id();
    // Token bucket (per client): refill by elapsed time, one token per request.
    const Clock::time_point now = Clock::now();
    tokens_ =
        std::min(core_->config.request_burst, tokens_ + std::chrono::duration<double>(now - last_refill_).count() *
                                                            core_->config.max_requests_per_s);
    last_refill_ = now;
    if (tokens_ < 1.0) {
      queueResponse(makeError(
          id, v1::ERROR_CODE_RATE_LIMITED,
          "more than " + std::to_string(core_->config.max_requests_per_s) + " requests per second; request not run"));
    } else if (inFlight() >= core_->config.max_in_flight) {
      tokens_ -= 1.0;
      queueResponse(makeError(id, v1::ERROR_CODE_TOO_MANY_IN_FLIGHT,
                              std::to_string(inFlight()) + " requests still being answered (max " +
                                  std::to_string(core_->config.max_in_flight) + "); request not run"));
    } else {
      tokens_ -= 1.0;
      Reply reply = core_->dispatcher.handle(request, state_);
      for (const v1::Envelope& e : reply.frames) queueResponse(e);
      if (reply.chunks) transfers_.push_back(std::move(reply.chunks));
      if (reply.disconnect) {
        ++core_->n_protocol_errors;
        beginClose();
        return;
      }
    }
    if (responses_.size() > core_->config.max_queued_responses) {
      ++core_->n_slow;
      core_->log(LogLevel::kWarning, state_.peer + ": " + std::to_string(responses_.size()) +
                                         " responses unread; disconnecting a client that cannot keep up");
      closeNow();
    }
  }

  void queueResponse(const v1::Envelope& e) {
    std::string frame;
    if (Status s = appendFrame(e, core_->config.dispatch.max_frame_bytes, frame); !s.ok()) {
      core_->log(LogLevel::kError, state_.peer + ": reply not sent: " + s.error().message);
      frame.clear();
      (void)appendFrame(makeError(e.request_id(), v1::ERROR_CODE_INTERNAL, s.error().message),
                        core_->config.dispatch.max_frame_bytes, frame);
    }
    responses_.push_back(std::move(frame));
  }

  void beginClose() {
    if (closing_ || closed_) return;
    closing_ = true;
    waypoints_.clear();
    pose_.reset();
    status_.reset();
    transfers_.clear();
    close_timer_.expires_after(core_->config.close_timeout);
    close_timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
      if (!ec) self->closeNow();
    });
    pump();
  }

  void appendStream(const v1::Envelope& e) {
    if (Status s = appendFrame(e, core_->config.dispatch.max_frame_bytes, out_); !s.ok()) {
      core_->log(LogLevel::kError, state_.peer + ": stream message not sent: " + s.error().message);
    }
  }

  void pump() {
    if (writing_ || closed_) return;
    out_.clear();
    while (out_.size() < kWriteBatchBytes) {
      if (!responses_.empty()) {
        out_ += responses_.front();
        responses_.pop_front();
        continue;
      }
      if (closing_) break;
      // Streams before transfer chunks: a waypoint never waits behind a map transfer.
      if (!waypoints_.empty()) {
        Waypoint w = waypoints_.front();
        waypoints_.pop_front();
        w.dropped = dropped_waypoints_;
        v1::Envelope e;
        toProto(w, *e.mutable_waypoint());
        appendStream(e);
        continue;
      }
      if (pose_) {
        PoseUpdate p = *pose_;
        pose_.reset();
        p.dropped = dropped_poses_;
        v1::Envelope e;
        toProto(p, *e.mutable_pose_update());
        appendStream(e);
        continue;
      }
      if (status_) {
        StatusUpdate s = std::move(*status_);
        status_.reset();
        s.dropped = dropped_status_;
        v1::Envelope e;
        toProto(s, *e.mutable_status_update());
        appendStream(e);
        continue;
      }
      if (!transfers_.empty()) {
        ChunkSource& source = *transfers_.front();
        if (Status s = appendFrame(source.next(), core_->config.dispatch.max_frame_bytes, out_); !s.ok()) {
          core_->log(LogLevel::kError, state_.peer + ": transfer aborted: " + s.error().message);
          (void)appendFrame(makeError(source.requestId(), v1::ERROR_CODE_INTERNAL, s.error().message),
                            core_->config.dispatch.max_frame_bytes, out_);
          transfers_.pop_front();
        } else if (source.done()) {
          transfers_.pop_front();
        }
        continue;
      }
      break;
    }
    if (out_.empty()) {
      if (closing_) closeNow();
      return;
    }
    writing_ = true;
    withStream([this](auto& stream) {
      asio::async_write(stream, asio::buffer(out_),
                        [self = shared_from_this()](const asio::error_code& ec, std::size_t) {
                          self->writing_ = false;
                          if (self->closed_) return;
                          if (ec) {
                            if (ec != asio::error::operation_aborted) {
                              self->core_->log(LogLevel::kInfo, self->state_.peer + ": write failed: " + ec.message());
                            }
                            self->closeNow();
                            return;
                          }
                          self->pump();
                        });
    });
  }

  std::shared_ptr<ApiServer::Core> core_;
  tcp::socket socket_;
  std::optional<asio::ssl::stream<tcp::socket&>> tls_;  // over socket_, when the server has TLS
  bool handshake_done_ = false;
  asio::steady_timer close_timer_;
  std::uint64_t id_;
  bool refused_;
  SessionState state_;
  FrameDecoder decoder_;
  std::array<std::uint8_t, kReadChunkBytes> read_buf_{};
  std::string out_;  // the batch being written; stable while writing_
  bool writing_ = false;
  bool closing_ = false;
  bool closed_ = false;
  bool forgotten_ = false;  // removed from Core::sessions and the client count
  double tokens_;
  Clock::time_point last_refill_;
  std::deque<std::string> responses_;  // encoded frames, never dropped
  std::deque<std::unique_ptr<ChunkSource>> transfers_;
  std::deque<Waypoint> waypoints_;
  std::optional<PoseUpdate> pose_;
  std::optional<StatusUpdate> status_;
  std::uint64_t dropped_waypoints_ = 0;
  std::uint64_t dropped_poses_ = 0;
  std::uint64_t dropped_status_ = 0;
};

std::size_t ApiServer::Core::activeClients() const {
  std::size_t n = 0;
  for (const auto& [id, weak] : sessions) {
    if (const auto s = weak.lock()) n += s->refused() ? 0 : 1;
  }
  return n;
}

void ApiServer::Core::accept() {
  acceptor.async_accept([core = shared_from_this()](const asio::error_code& ec, tcp::socket socket) {
    if (core->stopped) return;
    if (ec) {
      if (ec == asio::error::operation_aborted) return;
      core->log(LogLevel::kWarning, "accept failed: " + ec.message());
    } else {
      asio::error_code opt_ec;
      socket.set_option(tcp::no_delay(true), opt_ec);  // waypoint latency: no Nagle delay
      if (core->config.socket_send_buffer_bytes > 0) {
        socket.set_option(asio::socket_base::send_buffer_size(core->config.socket_send_buffer_bytes), opt_ec);
      }
      const bool refuse = core->activeClients() >= core->config.max_clients;
      const std::uint64_t id = core->next_session_id++;
      auto session = std::make_shared<Session>(core, std::move(socket), id, refuse);
      core->sessions.emplace(id, session);
      if (refuse) {
        ++core->n_refused;
        core->log(LogLevel::kWarning,
                  session->peer() + ": refused, " + std::to_string(core->config.max_clients) + " clients connected");
      } else {
        ++core->n_accepted;
        ++core->n_clients;
        core->log(LogLevel::kInfo, session->peer() + ": connected");
      }
      session->start();
    }
    core->accept();
  });
}

std::vector<std::shared_ptr<Session>> ApiServer::Core::sessionList() const {
  std::vector<std::shared_ptr<Session>> all;
  all.reserve(sessions.size());
  for (const auto& [id, weak] : sessions) {
    if (auto s = weak.lock()) all.push_back(std::move(s));
  }
  return all;
}

void ApiServer::Core::closeAll() {
  stopped = true;
  asio::error_code ec;
  acceptor.close(ec);
  for (auto& s : sessionList()) s->closeNow();
}

Status ApiServerConfig::validate() const {
  if (Status s = dispatch.validate(); !s.ok()) return s;
  if (max_clients < 1 || max_clients > 4096) {
    return Error{"api.max_clients: " + std::to_string(max_clients) + " is outside [1, 4096]"};
  }
  if (max_in_flight < 1 || max_in_flight > 1024) {
    return Error{"api.max_in_flight: " + std::to_string(max_in_flight) + " is outside [1, 1024]"};
  }
  if (!(max_requests_per_s > 0.0) || !(max_requests_per_s <= 1e6)) {
    return Error{"api.max_requests_per_s: " + std::to_string(max_requests_per_s) + " is outside (0, 1e6]"};
  }
  if (!(request_burst >= 1.0) || !(request_burst <= 1e6)) {
    return Error{"api.request_burst: " + std::to_string(request_burst) + " is outside [1, 1e6]"};
  }
  if (max_queued_responses < max_in_flight || max_queued_responses > 65536) {
    return Error{"api.max_queued_responses: " + std::to_string(max_queued_responses) + " is outside [max_in_flight " +
                 std::to_string(max_in_flight) + ", 65536]"};
  }
  if (max_queued_waypoints < 1 || max_queued_waypoints > 65536) {
    return Error{"api.max_queued_waypoints: " + std::to_string(max_queued_waypoints) + " is outside [1, 65536]"};
  }
  if (socket_send_buffer_bytes < 0) {
    return Error{"api.socket_send_buffer_bytes: " + std::to_string(socket_send_buffer_bytes) + " is negative"};
  }
  if (close_timeout.count() < 1 || close_timeout.count() > 60000) {
    return Error{"api.close_timeout_ms: " + std::to_string(close_timeout.count()) + " is outside [1, 60000]"};
  }
  if (tls.enabled() && tls.private_key_file.empty())
    return Error{"api.tls.private_key_file: required with a certificate"};
  if (tls.handshake_timeout.count() < 1 || tls.handshake_timeout.count() > 600000) {
    return Error{"api.tls.handshake_timeout_ms: " + std::to_string(tls.handshake_timeout.count()) +
                 " is outside [1, 600000]"};
  }
  return {};
}

namespace {

Result<std::unique_ptr<asio::ssl::context>> makeTlsContext(const TlsServerConfig& c) {
  auto context = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_server);
  asio::error_code ec;
  context->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                           asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                           asio::ssl::context::no_tlsv1_1 | asio::ssl::context::single_dh_use,
                       ec);
  if (!ec) context->use_certificate_chain_file(c.certificate_chain_file.string(), ec);
  if (ec)
    return Error{"api.tls.certificate_file: cannot use " + c.certificate_chain_file.string() + ": " + ec.message()};
  context->use_private_key_file(c.private_key_file.string(), asio::ssl::context::pem, ec);
  if (ec) return Error{"api.tls.private_key_file: cannot use " + c.private_key_file.string() + ": " + ec.message()};
  if (::SSL_CTX_check_private_key(context->native_handle()) != 1)
    return Error{"api.tls.private_key_file: " + c.private_key_file.string() + " does not match the certificate"};
  return context;
}

}  // namespace

Result<std::unique_ptr<ApiServer>> ApiServer::create(asio::io_context& io, ApiBackend& backend, ApiServerConfig config,
                                                     ApiLogger* logger, std::unique_ptr<NonceSource> nonces) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  if (!nonces) nonces = std::make_unique<SystemNonceSource>();
  std::unique_ptr<asio::ssl::context> tls;
  if (config.tls.enabled()) {
    auto context = makeTlsContext(config.tls);
    if (!context) return context.error();
    tls = std::move(context).value();
  }
  auto core = std::make_shared<Core>(io, backend, std::move(config), logger, std::move(nonces), std::move(tls));
  return std::unique_ptr<ApiServer>(new ApiServer(std::move(core)));
}

ApiServer::ApiServer(std::shared_ptr<Core> core) : core_(std::move(core)) {}

ApiServer::~ApiServer() { stop(); }

Result<std::uint16_t> ApiServer::listen(const std::string& address, std::uint16_t port) {
  asio::error_code ec;
  const asio::ip::address addr = asio::ip::make_address(address, ec);
  if (ec) return Error{"api.listen_address: '" + address + "' is not an IP address"};
  const tcp::endpoint endpoint(addr, port);
  tcp::acceptor& acceptor = core_->acceptor;
  if (acceptor.is_open()) return Error{"api server is already listening"};
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    asio::error_code ignored;
    acceptor.close(ignored);
    return Error{"api: cannot listen on " + address + ":" + std::to_string(port) + ": " + ec.message()};
  }
  const std::uint16_t bound = acceptor.local_endpoint(ec).port();
  core_->log(LogLevel::kInfo, "api listening on " + address + ":" + std::to_string(bound));
  core_->accept();
  return bound;
}

void ApiServer::publishWaypoint(const Waypoint& waypoint) {
  Waypoint w = waypoint;
  w.seq = ++core_->waypoint_seq;
  w.dropped = 0;
  w.published_unix_ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  ++core_->n_waypoints;
  asio::post(core_->io, [core = core_, w] {
    for (auto& s : core->sessionList()) s->pushWaypoint(w);
  });
}

void ApiServer::publishPose(const PoseUpdate& pose) {
  PoseUpdate p = pose;
  p.seq = ++core_->pose_seq;
  p.dropped = 0;
  asio::post(core_->io, [core = core_, p] {
    for (auto& s : core->sessionList()) s->pushPose(p);
  });
}

void ApiServer::publishStatus(const StatusReport& status) {
  auto update = std::make_shared<const StatusUpdate>(StatusUpdate{++core_->status_seq, status, 0});
  asio::post(core_->io, [core = core_, update] {
    for (auto& s : core->sessionList()) s->pushStatus(*update);
  });
}

void ApiServer::stop() {
  asio::post(core_->io, [core = core_] { core->closeAll(); });
}

ApiServerStats ApiServer::stats() const {
  ApiServerStats s;
  s.clients = core_->n_clients.load();
  s.accepted = core_->n_accepted.load();
  s.refused_full = core_->n_refused.load();
  s.protocol_errors = core_->n_protocol_errors.load();
  s.slow_disconnects = core_->n_slow.load();
  s.stream_drops = core_->n_drops.load();
  s.waypoint_drops = core_->n_waypoint_drops.load();
  s.waypoints_published = core_->n_waypoints.load();
  s.requests = core_->n_requests.load();
  s.tls_failures = core_->n_tls_failures.load();
  return s;
}

}  // namespace vog::api
