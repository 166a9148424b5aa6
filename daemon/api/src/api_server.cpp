#include "vog/api/api_server.hpp"

#include "vog/api/convert.hpp"
#include "vog/api/framing.hpp"
#include "vog/api/graph.hpp"
#include "vog/api/limits.hpp"
#include "vog/api/tls_context.hpp"

#include <asio.hpp>
#include <asio/ssl.hpp>

#include <algorithm>
#include <atomic>
#include <deque>
#include <optional>
#include <sstream>
#include <tuple>
#include <unordered_map>

namespace vog::api {

namespace {

using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

// Frames are gathered into one write of up to this many bytes (fewer syscalls for many small
// stream messages; one map chunk per write).
constexpr std::size_t kWriteBatchBytes = 256 * 1024;
constexpr std::size_t kReadChunkBytes = 64 * 1024;

std::string millis(Clock::duration d) {
  return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d).count()) + " ms";
}

}  // namespace

// Outside the anonymous namespace: ApiServer::Core, which holds one, has external linkage.
namespace detail {

// Failed authentications per peer address: the first kFreeFailures cost nothing, each later one
// makes the address wait kFirstWait, doubling up to kMaxWait. An address's record is forgotten
// kForgetAfter after its last failure or at its first success; at most kMaxPeers are kept (the one
// whose last failure is oldest goes first), so a flood of addresses cannot grow it.
// io thread only (owned by ApiServer::Core).
class AuthThrottle {
 public:
  static constexpr std::uint32_t kFreeFailures = 3;
  static constexpr Clock::duration kFirstWait = std::chrono::seconds(1);
  static constexpr Clock::duration kMaxWait = std::chrono::seconds(30);
  static constexpr Clock::duration kForgetAfter = std::chrono::minutes(10);
  static constexpr std::size_t kMaxPeers = 4096;

  // How long `address` must still wait before its next attempt (zero: it may try now).
  Clock::duration wait(const std::string& address, Clock::time_point now) const {
    const auto it = peers_.find(address);
    if (it == peers_.end() || it->second.allowed_at <= now) return Clock::duration::zero();
    return it->second.allowed_at - now;
  }
  std::uint32_t failures(const std::string& address) const {
    const auto it = peers_.find(address);
    return it == peers_.end() ? 0 : it->second.failures;
  }

  // Records a failure; returns the wait it imposes.
  Clock::duration failed(const std::string& address, Clock::time_point now) {
    auto it = peers_.find(address);
    if (it != peers_.end() && now - it->second.last_failure > kForgetAfter) it->second = {};
    if (it == peers_.end()) {
      if (peers_.size() >= kMaxPeers) forgetOldest();
      it = peers_.emplace(address, Peer{}).first;
    }
    Peer& p = it->second;
    ++p.failures;
    p.last_failure = now;
    Clock::duration wait = Clock::duration::zero();
    if (p.failures >= kFreeFailures) {
      const std::uint32_t doublings = std::min<std::uint32_t>(p.failures - kFreeFailures, 16);
      wait = std::min<Clock::duration>(kMaxWait, kFirstWait * (std::int64_t{1} << doublings));
    }
    p.allowed_at = now + wait;
    return wait;
  }

  void succeeded(const std::string& address) { peers_.erase(address); }

 private:
  struct Peer {
    std::uint32_t failures = 0;
    Clock::time_point last_failure{};
    Clock::time_point allowed_at{};
  };
  void forgetOldest() {
    const auto oldest = std::min_element(peers_.begin(), peers_.end(), [](const auto& a, const auto& b) {
      return a.second.last_failure < b.second.last_failure;
    });
    if (oldest != peers_.end()) peers_.erase(oldest);
  }
  std::unordered_map<std::string, Peer> peers_;
};

}  // namespace detail

using Session = ApiServer::Session;

struct ApiServer::Core : std::enable_shared_from_this<ApiServer::Core> {
  Core(asio::io_context& io_in, ApiBackend& backend_in, ApiServerConfig config_in, ApiLogger* logger_in,
       std::unique_ptr<NonceSource> nonces_in, std::unique_ptr<asio::ssl::context> tls_in)
      : io(io_in),
        backend(backend_in),
        config(std::move(config_in)),
        logger(logger_in),
        nonces(std::move(nonces_in)),
        tls(std::move(tls_in)),
        dispatcher(backend_in, *nonces, logger_in, config.dispatch),
        acceptor(io_in),
        accept_retry(io_in) {}

  void log(LogLevel level, const std::string& message) const {
    if (logger != nullptr) logger->log(level, message);
  }
  void accept();
  // Admits (or refuses) and starts the session of an accepted connection.
  void open(tcp::socket socket);
  // Makes room for a new connection from `address` when the server or the address's share is full,
  // by evicting a session (see the header); false when there is no room.
  bool admit(const std::string& address, std::string& why_not);
  void closeAll();
  // Sessions without a slot (refused, evicted, closing) stay open only to send their Error, at
  // most close_timeout each; beyond max_clients of them (a flood of connections) they are closed
  // at once, so that a flood cannot hold sockets beyond twice max_clients.
  bool tooManyLingering() const { return sessions.size() >= 2 * config.max_clients; }
  // A copy: a session may leave `sessions` while the caller walks the list.
  std::vector<std::shared_ptr<Session>> sessionList() const;
  // Adds `delta` to the queued bytes of all clients and raises the per-client high-water mark.
  void accountQueued(std::int64_t delta, std::size_t session_bytes) {
    queued_bytes += static_cast<std::uint64_t>(delta);
    if (session_bytes > max_session_queued_bytes.load()) max_session_queued_bytes = session_bytes;
  }

  asio::io_context& io;
  ApiBackend& backend;  // graph() for the graph stream; the dispatcher answers requests from it
  const ApiServerConfig config;
  ApiLogger* logger;
  std::unique_ptr<NonceSource> nonces;
  std::unique_ptr<asio::ssl::context> tls;  // null: plain TCP
  Dispatcher dispatcher;
  tcp::acceptor acceptor;
  asio::steady_timer accept_retry;     // after a failed accept (out of descriptors): wait, not spin
  bool stopped = false;                // io thread only
  std::uint64_t next_session_id = 1;   // io thread only
  detail::AuthThrottle auth_throttle;  // io thread only
  // Open sessions, for broadcasts. A session is owned by its pending asynchronous operations (each
  // handler holds a shared_ptr), never by this map: a session holds the Core, so owning it here
  // would be a cycle that outlives an io_context stopped with sessions open.
  std::unordered_map<std::uint64_t, std::weak_ptr<Session>> sessions;  // io thread only

  std::atomic<std::uint64_t> waypoint_seq{0};
  std::atomic<std::uint64_t> pose_seq{0};
  std::atomic<std::uint64_t> status_seq{0};
  // Counters read by stats() from any thread; written on the io thread.
  std::atomic<std::uint64_t> n_clients{0}, n_accepted{0}, n_refused{0}, n_protocol_errors{0}, n_slow{0}, n_drops{0},
      n_waypoint_drops{0}, n_waypoints{0}, n_requests{0}, n_tls_failures{0}, n_evicted{0}, n_hello_timeouts{0},
      n_idle_timeouts{0}, n_auth_failures{0}, n_auth_throttled{0}, queued_bytes{0}, max_session_queued_bytes{0};
};

// One client connection.
// Lifecycle: [handshaking (TLS only; at most tls.handshake_timeout)] -> open (reading requests,
// writing replies and streams) -> closing (an Error is queued; no more reads; only queued responses
// are flushed, for at most close_timeout) -> closed (socket closed, removed from Core::sessions).
// A session holds one of the server's slots from its admission until it is evicted or closed.
// Invariants: at most one async read and one async write in flight; no read is in flight while
// reading is paused for flow control; queues are bounded as the server header describes. io thread only.
class ApiServer::Session : public std::enable_shared_from_this<ApiServer::Session> {
 public:
  Session(std::shared_ptr<ApiServer::Core> core, tcp::socket socket, std::uint64_t id, std::string address,
          std::string refusal)
      : core_(std::move(core)),
        socket_(std::move(socket)),
        close_timer_(core_->io),
        activity_timer_(core_->io),
        write_timer_(core_->io),
        id_(id),
        address_(std::move(address)),
        refusal_(std::move(refusal)),
        holds_slot_(refusal_.empty()),
        decoder_(core_->config.dispatch.max_frame_bytes),
        tokens_(core_->config.request_burst),
        last_refill_(Clock::now()),
        connected_at_(last_refill_),
        last_request_at_(last_refill_) {
    asio::error_code ec;
    const auto ep = socket_.remote_endpoint(ec);
    state_.peer = ec ? std::string("unknown peer") : ep.address().to_string() + ":" + std::to_string(ep.port());
    if (core_->tls) tls_.emplace(socket_, *core_->tls);
  }

  // Destroyed without closeNow() only when the io_context is destroyed with this session's
  // operations pending: leave the server's books right.
  ~Session() { forget(); }

  bool holdsSlot() const { return holds_slot_; }
  const std::string& address() const { return address_; }
  const std::string& peer() const { return state_.peer; }

  // Eviction order (the server header): smaller is evicted first; nullopt: never evicted.
  std::optional<std::tuple<int, Clock::time_point>> evictionRank() const {
    if (!holds_slot_ || closing_ || closed_ || state_.role == Role::kOperator) return std::nullopt;
    if (!any_request_) return std::tuple{0, connected_at_};
    return std::tuple{subscribed() || busy() ? 2 : 1, last_request_at_};
  }

  // Gives up this session's slot to a new connection: TOO_MANY_CLIENTS, then closed.
  void evict(const std::string& why) {
    if (!holds_slot_) return;
    releaseSlot();
    ++core_->n_evicted;
    core_->log(LogLevel::kWarning, state_.peer + ": evicted (" + why + ") for a new connection");
    if (!began_ || core_->tooManyLingering()) {
      closeNow();
      return;
    }
    queueResponse(makeError(0, v1::ERROR_CODE_TOO_MANY_CLIENTS, "evicted for a new connection: " + why));
    beginClose();
  }

  void start() {
    armActivityTimer(connected_at_ + core_->config.hello_timeout);
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

  // The graph changed: this session gets what it lacks when its turn to write comes (one update that
  // spans every version it missed, so nothing is dropped and no resynchronisation is needed).
  void pushGraph() {
    if (closing_ || !state_.subscriptions.graph) return;
    graph_pending_ = true;
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
    activity_timer_.cancel();
    write_timer_.cancel();
    socket_.shutdown(tcp::socket::shutdown_both, ec);
    socket_.close(ec);
    forget();
  }

 private:
  // The session proper, after the TLS handshake if there is one.
  void begin() {
    began_ = true;
    if (!refusal_.empty()) {
      queueResponse(makeError(0, v1::ERROR_CODE_TOO_MANY_CLIENTS, refusal_));
      beginClose();
      return;
    }
    if (!holds_slot_) {  // evicted during the handshake
      closeNow();
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
    if (closing_ || closed_ || reading_ || paused_) return;
    reading_ = true;
    withStream([this](auto& stream) {
      stream.async_read_some(
          asio::buffer(read_buf_),
          [self = shared_from_this()](const asio::error_code& ec, std::size_t n) { self->onRead(ec, n); });
    });
  }

  void onRead(const asio::error_code& ec, std::size_t n) {
    reading_ = false;
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
    decodeRequests();
  }

  // Answers the buffered requests until the replies reach the queue limits (then pauses: the rest
  // waits in the decoder and the socket until the queue drains), then reads on.
  void decodeRequests() {
    paused_ = false;
    while (!closing_ && !closed_) {
      if (repliesFull()) {
        paused_ = true;
        break;
      }
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

  // No more requests are decoded while this holds (flow control, the server header).
  bool repliesFull() const { return responses_.size() >= core_->config.max_queued_responses || !roomForFrame(); }
  // One more frame of the maximum size fits in the client's queued-bytes budget.
  bool roomForFrame() const {
    return queuedBytes() + core_->config.dispatch.max_frame_bytes <= core_->config.max_queued_bytes;
  }
  std::size_t queuedBytes() const { return response_bytes_ + out_.size(); }
  bool subscribed() const {
    const Subscriptions& s = state_.subscriptions;
    return s.waypoints || s.poses || s.status || s.graph;
  }
  bool busy() const { return writing_ || !responses_.empty() || !transfers_.empty(); }

  void releaseSlot() {
    if (!holds_slot_) return;
    holds_slot_ = false;
    --core_->n_clients;
  }

  void forget() {
    if (forgotten_) return;
    forgotten_ = true;
    core_->sessions.erase(id_);
    releaseSlot();
    core_->accountQueued(-static_cast<std::int64_t>(accounted_bytes_), 0);
    accounted_bytes_ = 0;
  }

  // Reports this session's queued bytes to the server's figures.
  void account() {
    if (forgotten_) return;
    const std::size_t now = queuedBytes();
    core_->accountQueued(static_cast<std::int64_t>(now) - static_cast<std::int64_t>(accounted_bytes_), now);
    accounted_bytes_ = now;
  }

  // The hello and idle deadlines share one timer, re-armed lazily: a request only moves
  // last_request_at_, and the timer, when it fires, works out whether the deadline has moved on.
  void armActivityTimer(Clock::time_point at) {
    activity_timer_.expires_at(at);
    activity_timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
      if (!ec) self->onActivityTimer();
    });
  }

  void onActivityTimer() {
    if (closing_ || closed_) return;
    const Clock::time_point now = Clock::now();
    const ApiServerConfig& c = core_->config;
    if (!any_request_) {
      ++core_->n_hello_timeouts;
      timeOut("no complete request within " + millis(c.hello_timeout) + " of connecting (api.hello_timeout_ms)");
      return;
    }
    if (subscribed() || busy()) {
      armActivityTimer(now + c.idle_timeout);
      return;
    }
    const Clock::time_point deadline = last_request_at_ + c.idle_timeout;
    if (now < deadline) {
      armActivityTimer(deadline);
      return;
    }
    ++core_->n_idle_timeouts;
    timeOut("no request for " + millis(c.idle_timeout) + " and no subscription (api.idle_timeout_ms)");
  }

  void timeOut(const std::string& why) {
    core_->log(LogLevel::kInfo, state_.peer + ": " + why + "; disconnecting");
    if (!began_) {
      closeNow();
      return;
    }
    queueResponse(makeError(0, v1::ERROR_CODE_TIMED_OUT, why + "; disconnecting"));
    beginClose();
  }

  void handle(const v1::Envelope& request) {
    ++core_->n_requests;
    const std::uint64_t id = request.request_id();
    // Token bucket (per client): refill by elapsed time, one token per request.
    const Clock::time_point now = Clock::now();
    any_request_ = true;
    last_request_at_ = now;
    tokens_ =
        std::min(core_->config.request_burst, tokens_ + std::chrono::duration<double>(now - last_refill_).count() *
                                                            core_->config.max_requests_per_s);
    last_refill_ = now;
    if (tokens_ < 1.0) {
      queueResponse(makeError(
          id, v1::ERROR_CODE_RATE_LIMITED,
          "more than " + std::to_string(core_->config.max_requests_per_s) + " requests per second; request not run"));
      return;
    }
    tokens_ -= 1.0;
    if (inFlight() >= core_->config.max_in_flight) {
      queueResponse(makeError(id, v1::ERROR_CODE_TOO_MANY_IN_FLIGHT,
                              std::to_string(inFlight()) + " requests still being answered (max " +
                                  std::to_string(core_->config.max_in_flight) + "); request not run"));
      return;
    }
    const bool authenticating = request.has_challenge_response();
    if (authenticating) {
      if (const Clock::duration wait = core_->auth_throttle.wait(address_, now); wait > Clock::duration::zero()) {
        ++core_->n_auth_throttled;
        state_.pending_server_nonce.clear();  // a nonce answers one attempt, refused or not
        const std::string why = std::to_string(core_->auth_throttle.failures(address_)) +
                                " failed authentications from " + address_ + "; the next attempt is allowed in " +
                                millis(wait);
        core_->log(LogLevel::kWarning, state_.peer + ": authentication refused: " + why);
        queueResponse(makeError(id, v1::ERROR_CODE_RATE_LIMITED, why));
        return;
      }
    }
    const bool had_graph = state_.subscriptions.graph;
    Reply reply = core_->dispatcher.handle(request, state_);
    if (request.has_subscribe() && state_.subscriptions.graph != had_graph) {
      graph_sent_.reset();  // a new subscription starts with a full update
      graph_pending_ = state_.subscriptions.graph;
    }
    if (authenticating) {
      if (state_.role == Role::kOperator) {
        core_->auth_throttle.succeeded(address_);
      } else {
        ++core_->n_auth_failures;
        const Clock::duration wait = core_->auth_throttle.failed(address_, now);
        core_->log(LogLevel::kWarning,
                   state_.peer + ": " + std::to_string(core_->auth_throttle.failures(address_)) +
                       " failed authentications from " + address_ +
                       (wait > Clock::duration::zero() ? "; next attempt allowed in " + millis(wait) : std::string()));
      }
    }
    for (const v1::Envelope& e : reply.frames) queueResponse(e);
    if (reply.chunks) transfers_.push_back(std::move(reply.chunks));
    if (reply.disconnect) {
      ++core_->n_protocol_errors;
      beginClose();
    }
  }

  std::size_t inFlight() const { return responses_.size() + transfers_.size(); }

  void queueResponse(const v1::Envelope& e) {
    std::string frame;
    if (Status s = appendFrame(e, core_->config.dispatch.max_frame_bytes, frame); !s.ok()) {
      core_->log(LogLevel::kError, state_.peer + ": reply not sent: " + s.error().message);
      frame.clear();
      (void)appendFrame(makeError(e.request_id(), v1::ERROR_CODE_INTERNAL, s.error().message),
                        core_->config.dispatch.max_frame_bytes, frame);
    }
    response_bytes_ += frame.size();
    responses_.push_back(std::move(frame));
    account();
  }

  void beginClose() {
    if (closing_ || closed_) return;
    closing_ = true;
    waypoints_.clear();
    pose_.reset();
    status_.reset();
    transfers_.clear();
    activity_timer_.cancel();
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

  // Fills the next batch and starts writing it. Responses first (already queued and counted), then,
  // while a maximum frame fits in the budget, streams and the next chunk of the first transfer.
  void pump() {
    if (writing_ || closed_) return;
    out_.clear();
    while (out_.size() < kWriteBatchBytes) {
      if (!responses_.empty()) {
        response_bytes_ -= responses_.front().size();
        out_ += responses_.front();
        responses_.pop_front();
        continue;
      }
      if (closing_ || !roomForFrame()) break;
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
      if (graph_pending_) {
        graph_pending_ = false;
        std::shared_ptr<const GraphState> now = core_->backend.graph();
        if (now && (!graph_sent_ || graph_sent_->version != now->version)) {
          v1::Envelope e;
          toProto(graphUpdate(graph_sent_.get(), *now), *e.mutable_graph_update());
          appendStream(e);
          graph_sent_ = std::move(now);
        }
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
    account();
    if (out_.empty()) {
      if (closing_) closeNow();
      return;
    }
    writing_ = true;
    written_ = 0;
    write_deadline_ = Clock::now() + core_->config.write_timeout;
    if (!write_timer_armed_) armWriteTimer(write_deadline_);
    writeSome();
  }

  void writeSome() {
    withStream([this](auto& stream) {
      stream.async_write_some(
          asio::buffer(out_.data() + written_, out_.size() - written_),
          [self = shared_from_this()](const asio::error_code& ec, std::size_t n) { self->onWrite(ec, n); });
    });
  }

  void onWrite(const asio::error_code& ec, std::size_t n) {
    if (closed_) return;
    if (ec) {
      if (ec != asio::error::operation_aborted) {
        core_->log(LogLevel::kInfo, state_.peer + ": write failed: " + ec.message());
      }
      closeNow();
      return;
    }
    written_ += n;
    write_deadline_ = Clock::now() + core_->config.write_timeout;
    if (written_ < out_.size()) {
      writeSome();
      return;
    }
    writing_ = false;
    if (paused_ && !repliesFull()) {
      decodeRequests();  // pumps too
    } else {
      pump();
    }
  }

  // The write deadline moves with every byte written; the timer, when it fires, checks whether a
  // write is still waiting past it (one timer for the session's life, no re-arm per write).
  void armWriteTimer(Clock::time_point at) {
    write_timer_armed_ = true;
    write_timer_.expires_at(at);
    write_timer_.async_wait([self = shared_from_this()](const asio::error_code& ec) {
      self->write_timer_armed_ = false;
      if (!ec) self->onWriteTimer();
    });
  }

  void onWriteTimer() {
    if (closed_ || !writing_) return;
    if (Clock::now() < write_deadline_) {
      armWriteTimer(write_deadline_);
      return;
    }
    ++core_->n_slow;
    core_->log(LogLevel::kWarning, state_.peer + ": no byte written for " + millis(core_->config.write_timeout) +
                                       " with " + std::to_string(queuedBytes() - written_) +
                                       " bytes waiting; disconnecting a client that does not read");
    closeNow();
  }

  std::shared_ptr<ApiServer::Core> core_;
  tcp::socket socket_;
  std::optional<asio::ssl::stream<tcp::socket&>> tls_;  // over socket_, when the server has TLS
  bool handshake_done_ = false;
  asio::steady_timer close_timer_;     // TLS handshake, then closing
  asio::steady_timer activity_timer_;  // hello and idle deadlines
  asio::steady_timer write_timer_;     // write progress deadline
  std::uint64_t id_;
  std::string address_;  // the peer's address without port: per-peer limits
  std::string refusal_;  // non-empty: refused at accept, this is why
  bool holds_slot_;      // counted in Core::n_clients
  SessionState state_;
  FrameDecoder decoder_;
  std::array<std::uint8_t, kReadChunkBytes> read_buf_{};
  std::string out_;  // the batch being written; stable while writing_
  std::size_t written_ = 0;
  Clock::time_point write_deadline_;
  bool write_timer_armed_ = false;
  bool began_ = false;  // past the TLS handshake: frames can be sent
  bool reading_ = false;
  bool paused_ = false;  // not reading: the replies are at their limits
  bool writing_ = false;
  bool closing_ = false;
  bool closed_ = false;
  bool forgotten_ = false;  // removed from Core::sessions and the client count
  double tokens_;
  Clock::time_point last_refill_;
  Clock::time_point connected_at_;
  Clock::time_point last_request_at_;
  bool any_request_ = false;
  std::deque<std::string> responses_;  // encoded frames, never dropped
  std::size_t response_bytes_ = 0;     // their total size
  std::size_t accounted_bytes_ = 0;    // queuedBytes() as last added to the server's figures
  std::deque<std::unique_ptr<ChunkSource>> transfers_;
  std::deque<Waypoint> waypoints_;
  std::optional<PoseUpdate> pose_;
  std::optional<StatusUpdate> status_;
  bool graph_pending_ = false;                    // the graph changed since graph_sent_
  std::shared_ptr<const GraphState> graph_sent_;  // what this client holds (null: nothing yet)
  std::uint64_t dropped_waypoints_ = 0;
  std::uint64_t dropped_poses_ = 0;
  std::uint64_t dropped_status_ = 0;
};

bool ApiServer::Core::admit(const std::string& address, std::string& why_not) {
  std::size_t total = 0;
  std::size_t same = 0;
  for (const auto& s : sessionList()) {
    if (!s->holdsSlot()) continue;
    ++total;
    same += s->address() == address ? 1 : 0;
  }
  const bool peer_full = same >= config.max_clients_per_peer;
  const bool server_full = total >= config.max_clients;
  if (!peer_full && !server_full) return true;
  const std::string limit = peer_full ? std::to_string(config.max_clients_per_peer) + " clients from " + address +
                                            " (api.max_clients_per_peer)"
                                      : std::to_string(config.max_clients) + " clients (api.max_clients)";
  std::shared_ptr<Session> victim;
  std::optional<std::tuple<int, Clock::time_point>> victim_rank;
  for (auto& s : sessionList()) {
    if (peer_full && s->address() != address) continue;
    const auto rank = s->evictionRank();
    if (rank && (!victim_rank || *rank < *victim_rank)) {
      victim = s;
      victim_rank = rank;
    }
  }
  if (!victim) {
    why_not = "the server has " + limit + " already, all authenticated operators";
    return false;
  }
  victim->evict("the server has " + limit);
  return true;
}

void ApiServer::Core::accept() {
  acceptor.async_accept([core = shared_from_this()](const asio::error_code& ec, tcp::socket socket) {
    if (core->stopped) return;
    if (!ec) {
      core->open(std::move(socket));
      core->accept();
      return;
    }
    if (ec == asio::error::operation_aborted) return;
    core->log(LogLevel::kWarning, "accept failed: " + ec.message() + "; retrying in 100 ms");
    core->accept_retry.expires_after(std::chrono::milliseconds(100));
    core->accept_retry.async_wait([core](const asio::error_code& wait_ec) {
      if (!wait_ec && !core->stopped) core->accept();
    });
  });
}

void ApiServer::Core::open(tcp::socket socket) {
  asio::error_code ec;
  socket.set_option(tcp::no_delay(true), ec);  // waypoint latency: no Nagle delay
  if (config.socket_send_buffer_bytes > 0) {
    socket.set_option(asio::socket_base::send_buffer_size(config.socket_send_buffer_bytes), ec);
  }
  const auto endpoint = socket.remote_endpoint(ec);
  const std::string address = ec ? std::string("unknown") : endpoint.address().to_string();
  std::string refusal;
  const bool admitted = admit(address, refusal);
  if (!admitted && tooManyLingering()) {
    ++n_refused;
    socket.close(ec);  // a flood: no Error, no session
    return;
  }
  const std::uint64_t id = next_session_id++;
  auto session = std::make_shared<Session>(shared_from_this(), std::move(socket), id, address, refusal);
  sessions.emplace(id, session);
  if (!admitted) {
    ++n_refused;
    log(LogLevel::kWarning, session->peer() + ": refused: " + refusal);
  } else {
    ++n_accepted;
    ++n_clients;
    log(LogLevel::kInfo, session->peer() + ": connected");
  }
  session->start();
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
  accept_retry.cancel();
  for (auto& s : sessionList()) s->closeNow();
}

namespace {

// "api.KEY: VALUE is outside [MIN, MAX]" unless `range` contains `value`.
template <class T, class V>
Status checkRange(const char* key, V value, Range<T> range) {
  if (range.contains(static_cast<T>(value))) return {};
  const auto text = [](auto v) {
    std::ostringstream out;
    out << v;
    return out.str();
  };
  return Error{std::string("api.") + key + ": " + text(value) + " is outside [" + text(range.min) + ", " +
               text(range.max) + "]"};
}

}  // namespace

Status ApiServerConfig::validate() const {
  namespace lim = limits;
  if (Status s = dispatch.validate(); !s.ok()) return s;
  for (Status s : {
           checkRange("max_clients", max_clients, lim::kMaxClients),
           checkRange("max_clients_per_peer", max_clients_per_peer, lim::kMaxClientsPerPeer),
           checkRange("max_in_flight", max_in_flight, lim::kMaxInFlight),
           // NaN is outside every range: the comparisons are false.
           checkRange("max_requests_per_s", max_requests_per_s, lim::kMaxRequestsPerS),
           checkRange("request_burst", request_burst, lim::kRequestBurst),
           checkRange("max_queued_waypoints", max_queued_waypoints, lim::kMaxQueuedWaypoints),
           checkRange("socket_send_buffer_bytes", socket_send_buffer_bytes, lim::kSocketSendBufferBytes),
           checkRange("close_timeout_ms", close_timeout.count(), lim::kCloseTimeoutMs),
           checkRange("hello_timeout_ms", hello_timeout.count(), lim::kHelloTimeoutMs),
           checkRange("idle_timeout_ms", idle_timeout.count(), lim::kIdleTimeoutMs),
           checkRange("write_timeout_ms", write_timeout.count(), lim::kWriteTimeoutMs),
           checkRange("tls.handshake_timeout_ms", tls.handshake_timeout.count(), lim::kTlsHandshakeTimeoutMs),
       }) {
    if (!s.ok()) return s;
  }
  // Every request gets its reply queued: the queue holds a full in-flight window.
  if (max_queued_responses < max_in_flight || !lim::kMaxQueuedResponses.contains(max_queued_responses)) {
    return Error{"api.max_queued_responses: " + std::to_string(max_queued_responses) + " is outside [max_in_flight " +
                 std::to_string(max_in_flight) + ", " + std::to_string(lim::kMaxQueuedResponses.max) + "]"};
  }
  // Nothing is queued unless a frame of the maximum size fits in the budget.
  if (max_queued_bytes < dispatch.max_frame_bytes || !lim::kMaxQueuedBytes.contains(max_queued_bytes)) {
    return Error{"api.max_queued_bytes: " + std::to_string(max_queued_bytes) + " is outside [max_frame_bytes " +
                 std::to_string(std::max<std::uint64_t>(dispatch.max_frame_bytes, lim::kMaxQueuedBytes.min)) + ", " +
                 std::to_string(lim::kMaxQueuedBytes.max) + "]"};
  }
  if (tls.enabled() && tls.private_key_file.empty())
    return Error{"api.tls.private_key_file: required with a certificate"};
  return {};
}

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

namespace {
std::int64_t unixNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}
}  // namespace

void ApiServer::publishWaypoint(const Waypoint& waypoint) {
  Waypoint w = waypoint;
  w.seq = ++core_->waypoint_seq;
  w.dropped = 0;
  w.published_unix_ns = unixNowNs();
  ++core_->n_waypoints;
  asio::post(core_->io, [core = core_, w] {
    for (auto& s : core->sessionList()) s->pushWaypoint(w);
  });
}

void ApiServer::publishPose(const PoseUpdate& pose) {
  PoseUpdate p = pose;
  p.seq = ++core_->pose_seq;
  p.dropped = 0;
  p.published_unix_ns = unixNowNs();
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

void ApiServer::publishGraph() {
  asio::post(core_->io, [core = core_] {
    for (auto& s : core->sessionList()) s->pushGraph();
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
  s.evicted = core_->n_evicted.load();
  s.hello_timeouts = core_->n_hello_timeouts.load();
  s.idle_timeouts = core_->n_idle_timeouts.load();
  s.auth_failures = core_->n_auth_failures.load();
  s.auth_throttled = core_->n_auth_throttled.load();
  s.queued_bytes = core_->queued_bytes.load();
  s.max_session_queued_bytes = core_->max_session_queued_bytes.load();
  return s;
}

}  // namespace vog::api
