#include "vog/console/web_server.hpp"

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cctype>
#include <deque>
#include <fstream>
#include <optional>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace vog::console {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace fs = std::filesystem;
using tcp = asio::ip::tcp;

namespace {

using Request = http::request<http::string_body>;
using Response = http::response<http::string_body>;

constexpr std::size_t kMaxFileBytes = 16u << 20;
constexpr std::uint32_t kMaxHeaderBytes = 16 * 1024;
constexpr std::uint64_t kMaxRequestBodyBytes = 4096;  // GET and HEAD carry none
// Connections being answered 503 at once; beyond, a new one is closed without an answer (so a flood
// of connections cannot grow memory). Each gets kRefuseTimeout to send its request.
constexpr std::size_t kMaxRefusing = 64;
constexpr std::chrono::seconds kRefuseTimeout{5};
constexpr std::chrono::milliseconds kAcceptRetry{100};  // after a failed accept (e.g. out of descriptors)
constexpr std::size_t kMaxCloseReasonBytes = 123;       // RFC 6455 5.5: control payload 125 = code + reason
constexpr std::string_view kBinaryRefused = R"({"type":"error","text":"binary messages are not accepted"})";
constexpr std::string_view kTokenCookie = "vog_token";

// Beast 1.74 speaks boost::string_view.
std::string_view sv(beast::string_view s) { return {s.data(), s.size()}; }
beast::string_view bsv(std::string_view s) { return {s.data(), s.size()}; }

// Equal without an early exit, so the time taken does not tell how much of a guess was right.
bool equalConstantTime(std::string_view a, std::string_view b) {
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (std::size_t i = 0; i < b.size(); ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    diff |= x ^ static_cast<unsigned char>(b[i]);
  }
  return diff == 0;
}

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// %XX decoded; nullopt for a malformed escape. `plus_is_space` for query values (form encoding).
std::optional<std::string> percentDecode(std::string_view s, bool plus_is_space) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%') {
      if (i + 2 >= s.size()) return std::nullopt;
      const int hi = hexValue(s[i + 1]);
      const int lo = hexValue(s[i + 2]);
      if (hi < 0 || lo < 0) return std::nullopt;
      out.push_back(static_cast<char>(hi * 16 + lo));
      i += 2;
    } else if (plus_is_space && s[i] == '+') {
      out.push_back(' ');
    } else {
      out.push_back(s[i]);
    }
  }
  return out;
}

// The value of `name` in a query string (first occurrence), decoded.
std::optional<std::string> queryParam(std::string_view query, std::string_view name) {
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view{} : query.substr(amp + 1);
    const std::size_t eq = pair.find('=');
    if (pair.substr(0, eq) != name) continue;
    if (eq == std::string_view::npos) return std::string{};
    return percentDecode(pair.substr(eq + 1), true);
  }
  return std::nullopt;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// Every value of cookie `name` over all Cookie headers ("a=1; b=2").
std::vector<std::string_view> cookieValues(const Request& req, std::string_view name) {
  std::vector<std::string_view> values;
  for (auto it = req.find(http::field::cookie); it != req.end() && it->name() == http::field::cookie; ++it) {
    std::string_view rest = sv(it->value());
    while (!rest.empty()) {
      const std::size_t semi = rest.find(';');
      const std::string_view pair = trim(rest.substr(0, semi));
      rest = semi == std::string_view::npos ? std::string_view{} : rest.substr(semi + 1);
      const std::size_t eq = pair.find('=');
      if (eq != std::string_view::npos && pair.substr(0, eq) == name) values.push_back(pair.substr(eq + 1));
    }
  }
  return values;
}

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// "host[:port]" or "[v6]:port" -> lower-case host and port (default_port when absent).
std::pair<std::string, std::string> splitHostPort(std::string_view s, std::string_view default_port) {
  std::size_t host_end = std::string_view::npos;
  if (!s.empty() && s.front() == '[') {
    const std::size_t close = s.find(']');
    if (close == std::string_view::npos) return {lower(s), std::string(default_port)};
    host_end = close + 1;
  } else {
    host_end = s.find(':');
  }
  if (host_end >= s.size()) return {lower(s), std::string(default_port)};
  const std::string_view host = s.substr(0, host_end);
  std::string_view port = s.substr(host_end);
  if (!port.empty() && port.front() == ':') port.remove_prefix(1);
  return {lower(host), std::string(port.empty() ? default_port : port)};
}

// Whether an Origin ("scheme://host[:port]") names the host:port of a Host header.
bool sameOrigin(std::string_view origin, std::string_view host) {
  const std::size_t sep = origin.find("://");
  if (sep == std::string_view::npos || host.empty()) return false;
  const std::string scheme = lower(origin.substr(0, sep));
  const std::string_view authority = origin.substr(sep + 3);
  if (authority.empty() || authority.find_first_of("/?#@") != std::string_view::npos) return false;
  const std::string_view default_port = scheme == "https" ? "443" : scheme == "http" ? "80" : "";
  if (default_port.empty()) return false;
  return splitHostPort(authority, default_port) == splitHostPort(host, default_port);
}

std::string_view contentType(const fs::path& file) {
  const std::string ext = lower(file.extension().string());
  if (ext == ".html" || ext == ".htm") return "text/html; charset=utf-8";
  if (ext == ".js" || ext == ".mjs") return "text/javascript";
  if (ext == ".css") return "text/css";
  if (ext == ".json" || ext == ".map") return "application/json";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  return "application/octet-stream";
}

// The file a decoded request path names under root, or nullopt when it must not be served: a `..`
// segment, a backslash or a NUL anywhere, or a real path (symlinks resolved) outside root.
std::optional<fs::path> resolveUnder(const fs::path& root, std::string_view path) {
  if (path.find('\\') != std::string_view::npos || path.find('\0') != std::string_view::npos) return std::nullopt;
  fs::path candidate = root;
  bool any = false;
  while (!path.empty()) {
    const std::size_t slash = path.find('/');
    const std::string_view segment = path.substr(0, slash);
    path = slash == std::string_view::npos ? std::string_view{} : path.substr(slash + 1);
    if (segment == "..") return std::nullopt;
    if (segment.empty() || segment == ".") continue;
    candidate /= fs::path(std::string(segment));
    any = true;
  }
  if (!any) candidate /= "index.html";
  std::error_code ec;
  const fs::path real = fs::canonical(candidate, ec);
  if (ec) return std::nullopt;
  const auto [r, c] = std::mismatch(root.begin(), root.end(), real.begin(), real.end());
  if (r != root.end()) return std::nullopt;
  if (!fs::is_regular_file(real, ec) || ec) return std::nullopt;
  return real;
}

// Cut to at most max bytes without splitting a UTF-8 sequence.
std::string cutUtf8(std::string s, std::size_t max) {
  if (s.size() <= max) return s;
  std::size_t n = max;
  while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xC0) == 0x80) --n;
  s.resize(n);
  return s;
}

bool tokenCharsOk(std::string_view token) {
  return std::all_of(token.begin(), token.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '.' ||
           c == '_' || c == '~';
  });
}

template <class T>
Status checkRange(const char* name, T value, T min, T max) {
  if (value >= min && value <= max) return Status::success();
  return Error{std::string("web.") + name + ": " + std::to_string(value) + " is outside [" + std::to_string(min) +
               ", " + std::to_string(max) + "]"};
}

}  // namespace

Status WebServerConfig::validate() const {
  boost::system::error_code ec;
  asio::ip::make_address(address, ec);
  if (ec) return Error{"web.address: '" + address + "' is not an IP address"};
  if (!tokenCharsOk(token)) return Error{"web.token: only letters, digits and -._~ are allowed"};
  for (Status s : {
           checkRange<std::size_t>("max_message_bytes", max_message_bytes, 1, 64u << 20),
           checkRange<std::size_t>("max_queued_bytes", max_queued_bytes, 64 * 1024, std::size_t{1} << 32),
           checkRange<std::size_t>("max_clients", max_clients, 1, 4096),
           checkRange<std::int64_t>("write_timeout_ms", write_timeout.count(), 1, 600000),
           checkRange<std::int64_t>("idle_timeout_ms", idle_timeout.count(), 100, 3600000),
       }) {
    if (!s.ok()) return s;
  }
  return Status::success();
}

// Outside the anonymous namespace: WebServer::Core, which holds them, has external linkage.
namespace detail {

class WsSession;

struct AtomicStats {
  std::atomic<std::uint64_t> http_requests{0}, ws_clients{0}, ws_opened{0}, refused_token{0}, refused_origin{0},
      oversize_messages{0}, binary_refused{0}, slow_closed{0}, queued_bytes{0}, refused_full{0};
};

// One frame waiting to be sent, or the close frame (data: its reason). Shared: a broadcast queues
// one copy for every client.
struct Outgoing {
  enum class Kind { kText, kBinary, kClose };
  Kind kind;
  std::shared_ptr<const std::string> data;
};

}  // namespace detail

struct WebServer::Core {
  Core(WebServerConfig c, WebServerCallbacks cb) : config(std::move(c)), callbacks(std::move(cb)) {}

  void accept();
  void onAccept(beast::error_code ec, tcp::socket socket);
  void send(ClientId id, detail::Outgoing out);
  void broadcast(detail::Outgoing out);
  void shutdown();

  // First member, so destroyed last: its destructor destroys the handlers still queued, and with
  // them the sessions they hold (whose destructors touch nothing of Core).
  asio::io_context io;
  const WebServerConfig config;
  const WebServerCallbacks callbacks;
  fs::path root;           // canonical web_root (empty: no files); set before the thread starts
  std::uint16_t port = 0;  // set before the thread starts
  detail::AtomicStats stats;

  // Web thread only (and the starting thread before the web thread exists):
  tcp::acceptor acceptor{io};
  asio::steady_timer accept_retry{io};
  std::size_t connections = 0;  // HTTP sessions + WebSocket sessions (handshaking or open)
  std::size_t refusing = 0;     // connections being answered 503
  ClientId next_id = 1;
  bool stopping = false;
  std::unordered_map<ClientId, std::shared_ptr<detail::WsSession>> sockets;  // open WebSockets
};

namespace detail {

using Core = WebServer::Core;

// One WebSocket, from the upgrade request to its end. Web thread only. Lifecycle: start() runs the
// handshake; once open it is registered in core.sockets under its id and one read is always pending
// until it fails; finish() (exactly once: failed handshake, failed read or stop) unregisters it,
// releases its connection slot and calls `closed` if it was opened. Invariant: queued_bytes_ is the
// size of the text/binary frames in queue_ (the one being written included), at most
// config.max_queued_bytes, and also counted in core.stats.queued_bytes until finish().
class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(Core& core, tcp::socket socket, Request request)
      : core_(core), ws_(std::move(socket)), request_(std::move(request)), write_timer_(core.io) {}

  void start() {
    websocket::stream_base::timeout timeouts{};
    timeouts.handshake_timeout = core_.config.write_timeout;  // the close handshake too
    timeouts.idle_timeout = core_.config.idle_timeout;
    timeouts.keep_alive_pings = true;
    ws_.set_option(timeouts);
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "vog-console"); }));
    ws_.read_message_max(core_.config.max_message_bytes);
    ws_.async_accept(request_, [self = shared_from_this()](beast::error_code ec) { self->onAccept(ec); });
  }

  void enqueue(Outgoing out) {
    if (close_queued_ || finished_) return;
    if (out.kind == Outgoing::Kind::kClose) {
      close_queued_ = true;
    } else {
      const std::size_t size = out.data->size();
      if (queued_bytes_ + size > core_.config.max_queued_bytes) {
        core_.stats.slow_closed.fetch_add(1, std::memory_order_relaxed);
        abort();
        return;
      }
      queued_bytes_ += size;
      core_.stats.queued_bytes.fetch_add(size, std::memory_order_relaxed);
    }
    queue_.push_back(std::move(out));
    write();
  }

  // Closes the socket at once (no close frame: a client that does not read would not get it). The
  // pending read then fails and ends the session.
  void abort() {
    if (aborted_) return;
    aborted_ = true;
    close_queued_ = true;
    write_timer_.cancel();
    beast::error_code ec;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ec);
    beast::get_lowest_layer(ws_).close();
  }

  void finish() {
    if (finished_) return;
    finished_ = true;
    abort();
    core_.stats.queued_bytes.fetch_sub(queued_bytes_, std::memory_order_relaxed);
    queued_bytes_ = 0;
    queue_.clear();  // a write in flight holds its own reference to its data
    --core_.connections;
    if (!open_) return;
    core_.sockets.erase(id_);
    core_.stats.ws_clients.fetch_sub(1, std::memory_order_relaxed);
    if (core_.callbacks.closed) core_.callbacks.closed(id_);
  }

 private:
  void onAccept(beast::error_code ec) {
    if (ec || core_.stopping) {
      finish();
      return;
    }
    request_ = {};
    id_ = core_.next_id++;
    open_ = true;
    core_.sockets.emplace(id_, shared_from_this());
    core_.stats.ws_opened.fetch_add(1, std::memory_order_relaxed);
    core_.stats.ws_clients.fetch_add(1, std::memory_order_relaxed);
    if (core_.callbacks.opened) core_.callbacks.opened(id_);
    read();
  }

  void read() {
    ws_.async_read(read_buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onRead(ec); });
  }

  void onRead(beast::error_code ec) {
    if (ec) {
      // Beast has already sent the close frame with code 1009 (too big) and closed the connection.
      if (ec == websocket::error::message_too_big)
        core_.stats.oversize_messages.fetch_add(1, std::memory_order_relaxed);
      finish();
      return;
    }
    const bool text = ws_.got_text();
    std::string message = text ? beast::buffers_to_string(read_buffer_.data()) : std::string{};
    read_buffer_.consume(read_buffer_.size());
    if (text) {
      if (core_.callbacks.text) core_.callbacks.text(id_, std::move(message));
    } else {
      core_.stats.binary_refused.fetch_add(1, std::memory_order_relaxed);
      static const auto refused = std::make_shared<const std::string>(kBinaryRefused);
      enqueue({Outgoing::Kind::kText, refused});
    }
    if (!finished_) read();
  }

  void write() {
    if (writing_ || queue_.empty() || aborted_) return;
    writing_ = true;
    const Outgoing& front = queue_.front();
    armWriteTimer();
    auto self = shared_from_this();
    if (front.kind == Outgoing::Kind::kClose) {
      const websocket::close_reason reason(websocket::close_code::normal, cutUtf8(*front.data, kMaxCloseReasonBytes));
      ws_.async_close(reason, [self](beast::error_code ec) { self->onWritten(ec, 0); });
      return;
    }
    ws_.text(front.kind == Outgoing::Kind::kText);
    // The handler keeps the data alive: finish() may clear the queue while the write is in flight.
    ws_.async_write(asio::buffer(*front.data), [self, data = front.data](beast::error_code ec, std::size_t) {
      self->onWritten(ec, data->size());
    });
  }

  void onWritten(beast::error_code ec, std::size_t size) {
    writing_ = false;
    write_timer_.cancel();
    if (finished_) return;
    if (ec) {
      abort();
      return;
    }
    queue_.pop_front();
    queued_bytes_ -= size;
    core_.stats.queued_bytes.fetch_sub(size, std::memory_order_relaxed);
    write();
  }

  // A write that has not completed write_timeout after it started closes the client (one that does
  // not read: its socket buffers are full).
  void armWriteTimer() {
    const std::uint64_t seq = ++write_seq_;
    write_timer_.expires_after(core_.config.write_timeout);
    write_timer_.async_wait([self = shared_from_this(), seq](beast::error_code ec) {
      if (ec || seq != self->write_seq_ || !self->writing_ || self->aborted_) return;
      self->core_.stats.slow_closed.fetch_add(1, std::memory_order_relaxed);
      self->abort();
    });
  }

  Core& core_;
  websocket::stream<beast::tcp_stream> ws_;
  Request request_;  // the upgrade request, until the handshake completes
  beast::flat_buffer read_buffer_;
  asio::steady_timer write_timer_;
  std::deque<Outgoing> queue_;  // front: being written when writing_
  std::size_t queued_bytes_ = 0;
  std::uint64_t write_seq_ = 0;  // which write the timer is armed for
  ClientId id_ = 0;
  bool writing_ = false;
  bool close_queued_ = false;  // a close frame is queued or the socket is gone: nothing more is queued
  bool aborted_ = false;       // the socket is closed
  bool open_ = false;          // the handshake completed: registered in core.sockets under id_
  bool finished_ = false;
};

// One HTTP connection: requests read and answered in turn (keep-alive) until the peer closes, an
// error, idle_timeout, or an upgrade to /ws hands the socket to a WsSession. Web thread only. A
// refusing session (max_clients reached) answers its first request 503 and closes. finish() (once)
// releases its slot (refusing or connections) unless the socket went to a WsSession, which took it.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(Core& core, tcp::socket socket, bool refuse) : core_(core), stream_(std::move(socket)), refuse_(refuse) {}

  void start() { read(); }

 private:
  void read() {
    parser_.emplace();
    parser_->header_limit(kMaxHeaderBytes);
    parser_->body_limit(kMaxRequestBodyBytes);
    stream_.expires_after(refuse_ ? std::chrono::milliseconds(kRefuseTimeout) : core_.config.idle_timeout);
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onRead(ec); });
  }

  void onRead(beast::error_code ec) {
    if (ec == http::error::end_of_stream) {
      stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
      finish();
      return;
    }
    if (ec) {
      // A malformed request gets a 400 before the close; a socket error or timeout just the close.
      if (ec.category() == http::make_error_code(http::error::bad_target).category()) {
        Response res{http::status::bad_request, 11};
        res.set(http::field::content_type, "text/plain");
        res.body() = "bad request: " + ec.message() + "\n";
        res.prepare_payload();
        res.keep_alive(false);
        respond(std::move(res));
        return;
      }
      finish();
      return;
    }
    core_.stats.http_requests.fetch_add(1, std::memory_order_relaxed);
    const Request& req = parser_->get();
    if (refuse_) {
      respond(plain(req, http::status::service_unavailable, "too many clients\n", false));
      return;
    }
    handle(req);
  }

  void handle(const Request& req) {
    const std::string_view target = sv(req.target());
    const std::size_t q = target.find_first_of("?#");
    std::string_view query;
    if (q != std::string_view::npos && target[q] == '?') {
      query = target.substr(q + 1);
      query = query.substr(0, query.find('#'));
    }
    const std::optional<std::string> path = percentDecode(target.substr(0, q), false);
    if (!path || path->empty() || path->front() != '/') {
      respond(plain(req, http::status::bad_request, "bad request target\n", false));
      return;
    }
    const std::optional<std::string> query_token = queryParam(query, "token");
    const bool query_token_ok =
        !core_.config.token.empty() && query_token && equalConstantTime(*query_token, core_.config.token);
    if (!core_.config.token.empty() && !query_token_ok) {
      bool cookie_ok = false;
      for (std::string_view v : cookieValues(req, kTokenCookie)) cookie_ok |= equalConstantTime(v, core_.config.token);
      if (!cookie_ok) {
        core_.stats.refused_token.fetch_add(1, std::memory_order_relaxed);
        respond(plain(req, http::status::unauthorized,
                      "token missing or wrong: open the URL with ?token= that vog-console printed\n",
                      req.keep_alive()));
        return;
      }
    }
    if (req.method() != http::verb::get && req.method() != http::verb::head) {
      Response res = plain(req, http::status::method_not_allowed, "only GET and HEAD\n", req.keep_alive());
      res.set(http::field::allow, "GET, HEAD");
      respond(std::move(res));
      return;
    }
    if (*path == "/ws") {
      upgrade(req);
      return;
    }
    if (*path == "/api/state") {
      respond(state(req));
      return;
    }
    Response res = file(req, *path);
    if (query_token_ok && res.result() == http::status::ok && (*path == "/" || *path == "/index.html")) {
      res.set(http::field::set_cookie,
              std::string(kTokenCookie) + "=" + core_.config.token + "; HttpOnly; SameSite=Strict; Path=/");
    }
    respond(std::move(res));
  }

  void upgrade(const Request& req) {
    if (!websocket::is_upgrade(req)) {
      respond(plain(req, http::status::bad_request, "WebSocket upgrade required\n", req.keep_alive()));
      return;
    }
    const auto origin = req.find(http::field::origin);
    if (origin != req.end() && !sameOrigin(sv(origin->value()), sv(req[http::field::host]))) {
      core_.stats.refused_origin.fetch_add(1, std::memory_order_relaxed);
      respond(plain(req, http::status::forbidden, "WebSocket from another origin refused\n", false));
      return;
    }
    // The connection's slot goes with the socket.
    upgraded_ = true;
    stream_.expires_never();
    std::make_shared<WsSession>(core_, stream_.release_socket(), parser_->release())->start();
  }

  Response state(const Request& req) {
    if (!core_.callbacks.state_json) {
      return plain(req, http::status::service_unavailable, "no state yet\n", req.keep_alive());
    }
    std::string body;
    try {
      body = core_.callbacks.state_json();
    } catch (const std::exception& e) {
      return plain(req, http::status::internal_server_error, std::string("state: ") + e.what() + "\n",
                   req.keep_alive());
    }
    Response res = make(req, http::status::ok, "application/json", std::move(body), req.keep_alive());
    res.set(http::field::cache_control, "no-store");
    return res;
  }

  Response file(const Request& req, std::string_view path) {
    const std::optional<fs::path> real = core_.root.empty() ? std::nullopt : resolveUnder(core_.root, path);
    if (!real) return plain(req, http::status::not_found, "not found\n", req.keep_alive());
    std::ifstream in(*real, std::ios::binary);
    std::string body(kMaxFileBytes + 1, '\0');
    in.read(body.data(), static_cast<std::streamsize>(body.size()));
    if (in.bad() || (!in.eof() && !in)) {
      return plain(req, http::status::internal_server_error, "cannot read the file\n", req.keep_alive());
    }
    body.resize(static_cast<std::size_t>(in.gcount()));
    if (body.size() > kMaxFileBytes) {
      return plain(req, http::status::internal_server_error, "file larger than 16 MiB\n", req.keep_alive());
    }
    // The type follows the name asked for (a symlink's target may be named otherwise).
    const std::string_view name = path == "/" ? std::string_view("index.html") : path;
    return make(req, http::status::ok, contentType(fs::path(std::string(name))), std::move(body), req.keep_alive());
  }

  static Response make(const Request& req, http::status status, std::string_view type, std::string body,
                       bool keep_alive) {
    Response res{status, req.version()};
    res.set(http::field::server, "vog-console");
    res.set(http::field::content_type, bsv(type));
    res.set("X-Content-Type-Options", "nosniff");
    res.set("Referrer-Policy", "no-referrer");  // the page's URL may hold the token
    res.body() = std::move(body);
    res.prepare_payload();
    res.keep_alive(keep_alive);
    if (req.method() == http::verb::head) {
      const std::size_t size = res.body().size();
      res.body().clear();
      res.content_length(size);
    }
    return res;
  }

  static Response plain(const Request& req, http::status status, std::string body, bool keep_alive) {
    return make(req, status, "text/plain; charset=utf-8", std::move(body), keep_alive);
  }

  void respond(Response res) {
    response_ = std::move(res);
    stream_.expires_after(core_.config.write_timeout);
    http::async_write(stream_, response_,
                      [self = shared_from_this()](beast::error_code ec, std::size_t) { self->onWritten(ec); });
  }

  void onWritten(beast::error_code ec) {
    if (ec || !response_.keep_alive() || refuse_) {
      if (!ec) stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
      finish();
      return;
    }
    read();
  }

  void finish() {
    if (finished_ || upgraded_) return;
    finished_ = true;
    // A refused or finished connection is closed after its answer went out (shutdown above); the
    // peer's remaining bytes, if any, are not waited for.
    beast::error_code ec;
    stream_.socket().close(ec);
    if (refuse_) {
      --core_.refusing;
    } else {
      --core_.connections;
    }
  }

  Core& core_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  Response response_;  // being written
  const bool refuse_;
  bool upgraded_ = false;
  bool finished_ = false;
};

}  // namespace detail

void WebServer::Core::accept() {
  acceptor.async_accept([this](beast::error_code ec, tcp::socket socket) { onAccept(ec, std::move(socket)); });
}

void WebServer::Core::onAccept(beast::error_code ec, tcp::socket socket) {
  if (stopping || ec == asio::error::operation_aborted) return;
  if (ec) {
    accept_retry.expires_after(kAcceptRetry);
    accept_retry.async_wait([this](beast::error_code e) {
      if (!e && !stopping) accept();
    });
    return;
  }
  socket.set_option(tcp::no_delay(true), ec);
  const bool refuse = connections >= config.max_clients;
  if (refuse) {
    stats.refused_full.fetch_add(1, std::memory_order_relaxed);
    if (refusing >= kMaxRefusing) {
      socket.close(ec);
      accept();
      return;
    }
    ++refusing;
  } else {
    ++connections;
  }
  std::make_shared<detail::HttpSession>(*this, std::move(socket), refuse)->start();
  accept();
}

void WebServer::Core::send(ClientId id, detail::Outgoing out) {
  const auto it = sockets.find(id);
  if (it != sockets.end()) it->second->enqueue(std::move(out));
}

void WebServer::Core::broadcast(detail::Outgoing out) {
  // enqueue() may close a slow client, which leaves the map: iterate over a copy.
  std::vector<std::shared_ptr<detail::WsSession>> open;
  open.reserve(sockets.size());
  for (const auto& [id, session] : sockets) open.push_back(session);
  for (const auto& session : open) session->enqueue(out);
}

void WebServer::Core::shutdown() {
  stopping = true;
  beast::error_code ec;
  acceptor.close(ec);
  accept_retry.cancel();
  std::vector<std::shared_ptr<detail::WsSession>> open;
  for (const auto& [id, session] : sockets) open.push_back(session);
  for (const auto& session : open) session->finish();
  // HTTP sessions and handshakes still under way end with the io_context (their sockets close).
  io.stop();
}

Result<std::unique_ptr<WebServer>> WebServer::start(WebServerConfig config, WebServerCallbacks callbacks) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  auto core = std::make_unique<Core>(std::move(config), std::move(callbacks));
  const WebServerConfig& c = core->config;
  if (!c.web_root.empty()) {
    std::error_code fec;
    core->root = fs::canonical(c.web_root, fec);
    if (fec) return Error{"web.web_root: " + c.web_root.string() + ": " + fec.message()};
    if (!fs::is_directory(core->root, fec)) return Error{"web.web_root: " + c.web_root.string() + " is not a folder"};
  }
  beast::error_code ec;
  const tcp::endpoint endpoint(asio::ip::make_address(c.address, ec), c.port);
  if (!ec) core->acceptor.open(endpoint.protocol(), ec);
  if (!ec) core->acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) core->acceptor.bind(endpoint, ec);
  if (!ec) core->acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) return Error{"web: cannot listen on " + c.address + ":" + std::to_string(c.port) + ": " + ec.message()};
  core->port = core->acceptor.local_endpoint(ec).port();
  core->accept();
  std::unique_ptr<WebServer> server(new WebServer(std::move(core)));
  server->thread_ = std::thread([c = server->core_.get()] { c->io.run(); });
  return Result<std::unique_ptr<WebServer>>(std::move(server));
}

WebServer::WebServer(std::unique_ptr<Core> core) : core_(std::move(core)) {}

WebServer::~WebServer() { stop(); }

std::uint16_t WebServer::port() const { return core_->port; }

void WebServer::sendText(ClientId id, std::string text) {
  asio::post(core_->io, [c = core_.get(), id, data = std::make_shared<const std::string>(std::move(text))] {
    c->send(id, {detail::Outgoing::Kind::kText, data});
  });
}

void WebServer::sendBinary(ClientId id, std::string bytes) {
  asio::post(core_->io, [c = core_.get(), id, data = std::make_shared<const std::string>(std::move(bytes))] {
    c->send(id, {detail::Outgoing::Kind::kBinary, data});
  });
}

void WebServer::broadcastText(std::string text) {
  asio::post(core_->io, [c = core_.get(), data = std::make_shared<const std::string>(std::move(text))] {
    c->broadcast({detail::Outgoing::Kind::kText, data});
  });
}

void WebServer::close(ClientId id, std::string reason) {
  asio::post(core_->io, [c = core_.get(), id, data = std::make_shared<const std::string>(std::move(reason))] {
    c->send(id, {detail::Outgoing::Kind::kClose, data});
  });
}

void WebServer::stop() {
  std::lock_guard lock(stop_mutex_);
  if (!thread_.joinable()) return;
  assert(std::this_thread::get_id() != thread_.get_id() && "stop() from a callback would join its own thread");
  asio::post(core_->io, [c = core_.get()] { c->shutdown(); });
  thread_.join();
}

WebServerStats WebServer::stats() const {
  const detail::AtomicStats& s = core_->stats;
  constexpr auto r = std::memory_order_relaxed;
  WebServerStats out;
  out.http_requests = s.http_requests.load(r);
  out.ws_clients = s.ws_clients.load(r);
  out.ws_opened = s.ws_opened.load(r);
  out.refused_token = s.refused_token.load(r);
  out.refused_origin = s.refused_origin.load(r);
  out.oversize_messages = s.oversize_messages.load(r);
  out.binary_refused = s.binary_refused.load(r);
  out.slow_closed = s.slow_closed.load(r);
  out.queued_bytes = s.queued_bytes.load(r);
  out.refused_full = s.refused_full.load(r);
  return out;
}

}  // namespace vog::console
