// vog-console's web server against real Beast HTTP and WebSocket clients on loopback.

#include "vog/console/web_server.hpp"

#include "test_support.hpp"

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <gtest/gtest.h>

#include <condition_variable>
#include <fstream>
#include <functional>
#include <mutex>
#include <vector>

namespace vog::console {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace fs = std::filesystem;
using tcp = asio::ip::tcp;
using Response = http::response<http::string_body>;
using namespace std::chrono_literals;

std::string str(beast::string_view s) { return std::string(s.data(), s.size()); }

void writeFile(const fs::path& file, const std::string& content) {
  fs::create_directories(file.parent_path());
  std::ofstream(file, std::ios::binary) << content;
}

// What the server's callbacks saw, for the test thread to wait on.
class Events {
 public:
  WebServerCallbacks callbacks() {
    WebServerCallbacks cb;
    cb.opened = [this](ClientId id) { push([&] { opened_.push_back(id); }); };
    cb.closed = [this](ClientId id) { push([&] { closed_.push_back(id); }); };
    cb.text = [this](ClientId id, std::string text) { push([&] { texts_.emplace_back(id, std::move(text)); }); };
    return cb;
  }
  // Waits until pred (called under the lock) holds; false after 5 s.
  bool waitFor(const std::function<bool()>& pred) {
    std::unique_lock lock(mutex_);
    return cv_.wait_for(lock, 5s, pred);
  }
  std::vector<ClientId> opened() {
    std::lock_guard lock(mutex_);
    return opened_;
  }
  std::vector<ClientId> closed() {
    std::lock_guard lock(mutex_);
    return closed_;
  }
  std::vector<std::pair<ClientId, std::string>> texts() {
    std::lock_guard lock(mutex_);
    return texts_;
  }
  std::size_t nOpened() { return opened().size(); }
  bool waitOpened(std::size_t n) {
    return waitFor([&] { return opened_.size() >= n; });
  }
  bool waitClosed(std::size_t n) {
    return waitFor([&] { return closed_.size() >= n; });
  }
  bool waitTexts(std::size_t n) {
    return waitFor([&] { return texts_.size() >= n; });
  }

 private:
  void push(const std::function<void()>& f) {
    {
      std::lock_guard lock(mutex_);
      f();
    }
    cv_.notify_all();
  }
  std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<ClientId> opened_, closed_;                // guarded by mutex_
  std::vector<std::pair<ClientId, std::string>> texts_;  // guarded by mutex_
};

// One HTTP request on a fresh connection.
Response get(std::uint16_t port, const std::string& target,
             const std::vector<std::pair<std::string, std::string>>& fields = {}, http::verb verb = http::verb::get) {
  asio::io_context io;
  beast::tcp_stream stream(io);
  stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  http::request<http::string_body> req{verb, target, 11};
  req.set(http::field::host, "127.0.0.1:" + std::to_string(port));
  for (const auto& [name, value] : fields) req.set(name, value);
  http::write(stream, req);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.body_limit(64u << 20);
  if (verb == http::verb::head) parser.skip(true);
  http::read(stream, buffer, parser);
  return parser.release();
}

// A WebSocket client; connect() returns the handshake's HTTP response (101 when open).
class WsClient {
 public:
  explicit WsClient(std::uint16_t port) : port_(port), ws_(io_) {}

  Response connect(const std::string& target = "/ws", const std::string& origin = "", const std::string& cookie = "") {
    beast::get_lowest_layer(ws_).connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port_));
    ws_.set_option(websocket::stream_base::decorator([origin, cookie](websocket::request_type& req) {
      if (!origin.empty()) req.set(http::field::origin, origin);
      if (!cookie.empty()) req.set(http::field::cookie, cookie);
    }));
    // The asynchronous handshake hands back the response of a refused upgrade too.
    websocket::response_type res;
    ws_.async_handshake(res, "127.0.0.1:" + std::to_string(port_), target, [](beast::error_code) {});
    io_.run();
    io_.restart();
    Response out;
    out.result(res.result());
    out.body() = res.body();
    for (const auto& f : res) out.set(f.name_string(), f.value());
    return out;
  }
  void sendText(const std::string& text) {
    ws_.text(true);
    ws_.write(asio::buffer(text));
  }
  // Writes the header of a masked text frame announcing `size` bytes, and the first `sent` of them,
  // past the client's stream (so the client's own state is not failed by a broken pipe).
  void sendRawFrameStart(std::uint64_t size, std::size_t sent) {
    std::string frame{'\x81', '\xFF'};  // FIN + text; masked, 64-bit length
    for (int shift = 56; shift >= 0; shift -= 8) frame.push_back(static_cast<char>((size >> shift) & 0xFF));
    frame.append("\x11\x22\x33\x44");  // mask key
    frame.append(sent, 'b');
    beast::error_code ec;
    asio::write(beast::get_lowest_layer(ws_).socket(), asio::buffer(frame), ec);
  }
  void sendBinary(const std::string& bytes) {
    ws_.binary(true);
    ws_.write(asio::buffer(bytes));
  }
  // The next message, or the error that ended the read.
  std::pair<std::string, beast::error_code> read() {
    beast::flat_buffer buffer;
    beast::error_code ec;
    ws_.read(buffer, ec);
    return {beast::buffers_to_string(buffer.data()), ec};
  }
  bool gotText() const { return ws_.got_text(); }
  websocket::close_reason reason() const { return ws_.reason(); }
  websocket::stream<beast::tcp_stream>& stream() { return ws_; }

 private:
  std::uint16_t port_;
  asio::io_context io_;
  websocket::stream<beast::tcp_stream> ws_;
};

class WebServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = dir_.path() / "www";
    writeFile(root_ / "index.html", "<html>vog</html>");
    writeFile(root_ / "js" / "app.js", "console.log(1);");
    writeFile(root_ / "style.css", "body{}");
    writeFile(dir_.path() / "secret", "SECRET");
    writeFile(root_ / "a" / "inside.txt", "inside");
  }

  std::unique_ptr<WebServer> start(WebServerConfig config = {}, std::function<std::string()> state = nullptr) {
    config.address = "127.0.0.1";
    config.port = 0;
    config.web_root = root_;
    WebServerCallbacks cb = events_.callbacks();
    cb.state_json = std::move(state);
    auto server = WebServer::start(std::move(config), std::move(cb));
    EXPECT_TRUE(server.ok()) << (server.ok() ? "" : server.error().message);
    return server.ok() ? std::move(server).value() : nullptr;
  }

  test::TempDir dir_{"vog-web"};
  fs::path root_;
  Events events_;
};

TEST_F(WebServerTest, ServesIndexAndFilesWithTheirContentType) {
  auto server = start();
  ASSERT_TRUE(server);
  const Response index = get(server->port(), "/");
  EXPECT_EQ(index.result(), http::status::ok);
  EXPECT_EQ(index.body(), "<html>vog</html>");
  EXPECT_EQ(str(index[http::field::content_type]), "text/html; charset=utf-8");
  EXPECT_EQ(str(index["X-Content-Type-Options"]), "nosniff");

  const Response js = get(server->port(), "/js/app.js?v=3");
  EXPECT_EQ(js.result(), http::status::ok);
  EXPECT_EQ(js.body(), "console.log(1);");
  EXPECT_EQ(str(js[http::field::content_type]), "text/javascript");
  EXPECT_EQ(str(get(server->port(), "/style.css")[http::field::content_type]), "text/css");

  const Response head = get(server->port(), "/js/app.js", {}, http::verb::head);
  EXPECT_EQ(head.result(), http::status::ok);
  EXPECT_EQ(str(head[http::field::content_length]), "15");

  EXPECT_EQ(get(server->port(), "/missing.js").result(), http::status::not_found);
  EXPECT_EQ(get(server->port(), "/js/").result(), http::status::not_found);
  EXPECT_EQ(get(server->port(), "/", {}, http::verb::post).result(), http::status::method_not_allowed);
  EXPECT_GE(server->stats().http_requests, 7u);
}

TEST_F(WebServerTest, KeepAliveServesSeveralRequestsOnOneConnection) {
  auto server = start();
  ASSERT_TRUE(server);
  asio::io_context io;
  beast::tcp_stream stream(io);
  stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server->port()));
  beast::flat_buffer buffer;
  for (const std::string target : {"/", "/js/app.js", "/missing"}) {
    http::request<http::empty_body> req{http::verb::get, target, 11};
    req.set(http::field::host, "127.0.0.1");
    http::write(stream, req);
    Response res;
    http::read(stream, buffer, res);
    EXPECT_EQ(res.result(), target == "/missing" ? http::status::not_found : http::status::ok) << target;
  }
}

TEST_F(WebServerTest, RefusesEveryPathOutsideTheWebRoot) {
  fs::create_symlink(dir_.path() / "secret", root_ / "link");
  fs::create_directory_symlink(dir_.path(), root_ / "up");
  auto server = start();
  ASSERT_TRUE(server);
  ASSERT_EQ(test::readFile(dir_.path() / "secret"), "SECRET");
  for (const std::string target :
       {"/../secret", "/%2e%2e/secret", "/%2E%2E%2Fsecret", "/a/../../secret", "/a/..%2f..%2fsecret", "/link",
        "/up/secret", "/a%5c..%5c..%5csecret", "/a/inside.txt%00.js", "//secret", "/a/%zz"}) {
    const Response res = get(server->port(), target);
    EXPECT_TRUE(res.result() == http::status::not_found || res.result() == http::status::bad_request)
        << target << ": " << res.result_int();
    EXPECT_EQ(res.body().find("SECRET"), std::string::npos) << target;
  }
  // The same decoding still serves what is inside.
  EXPECT_EQ(get(server->port(), "/a/inside.txt").body(), "inside");
  EXPECT_EQ(get(server->port(), "/a/./inside%2etxt").body(), "inside");
}

TEST_F(WebServerTest, ApiStateServesTheCallbacksJson) {
  auto server = start({}, [] { return std::string(R"({"type":"status","n_submaps":3})"); });
  ASSERT_TRUE(server);
  const Response res = get(server->port(), "/api/state");
  EXPECT_EQ(res.result(), http::status::ok);
  EXPECT_EQ(res.body(), R"({"type":"status","n_submaps":3})");
  EXPECT_EQ(str(res[http::field::content_type]), "application/json");
  EXPECT_EQ(str(res[http::field::cache_control]), "no-store");

  auto bare = start();
  ASSERT_TRUE(bare);
  EXPECT_EQ(get(bare->port(), "/api/state").result(), http::status::service_unavailable);
}

TEST_F(WebServerTest, TokenIsRequiredByQueryOrCookie) {
  WebServerConfig config;
  config.token = "s3cret-Token";
  auto server = start(config, [] { return std::string("{}"); });
  ASSERT_TRUE(server);
  const std::uint16_t port = server->port();

  const Response missing = get(port, "/");
  EXPECT_EQ(missing.result(), http::status::unauthorized);
  EXPECT_NE(missing.body().find("token"), std::string::npos);
  EXPECT_EQ(missing.body().find("s3cret"), std::string::npos);
  EXPECT_EQ(get(port, "/?token=s3cret-Tokem").result(), http::status::unauthorized);
  EXPECT_EQ(get(port, "/?token=s3cret-Token2").result(), http::status::unauthorized);
  EXPECT_EQ(get(port, "/api/state", {{"Cookie", "vog_token=wrong"}}).result(), http::status::unauthorized);
  EXPECT_EQ(get(port, "/missing").result(), http::status::unauthorized);
  EXPECT_EQ(server->stats().refused_token, 5u);

  const Response query = get(port, "/?token=s3cret-Token");
  EXPECT_EQ(query.result(), http::status::ok);
  EXPECT_EQ(query.body(), "<html>vog</html>");
  EXPECT_EQ(str(query[http::field::set_cookie]), "vog_token=s3cret-Token; HttpOnly; SameSite=Strict; Path=/");

  const Response cookie = get(port, "/js/app.js", {{"Cookie", "theme=dark; vog_token=s3cret-Token"}});
  EXPECT_EQ(cookie.result(), http::status::ok);
  EXPECT_EQ(cookie.body(), "console.log(1);");
  EXPECT_EQ(cookie.count(http::field::set_cookie), 0u);
  EXPECT_EQ(get(port, "/api/state?token=s3cret-Token").body(), "{}");

  WsClient refused(port);
  EXPECT_EQ(refused.connect("/ws").result(), http::status::unauthorized);
  WsClient by_query(port);
  EXPECT_EQ(by_query.connect("/ws?token=s3cret-Token").result(), http::status::switching_protocols);
  WsClient by_cookie(port);
  EXPECT_EQ(by_cookie.connect("/ws", "", "vog_token=s3cret-Token").result(), http::status::switching_protocols);
  EXPECT_TRUE(events_.waitOpened(2));
  EXPECT_EQ(events_.nOpened(), 2u);
}

TEST_F(WebServerTest, RefusesAWebSocketFromAnotherOrigin) {
  auto server = start();
  ASSERT_TRUE(server);
  const std::string port = std::to_string(server->port());
  WsClient other_site(server->port());
  EXPECT_EQ(other_site.connect("/ws", "http://evil.example").result(), http::status::forbidden);
  WsClient other_port(server->port());
  EXPECT_EQ(other_port.connect("/ws", "http://127.0.0.1:1").result(), http::status::forbidden);
  EXPECT_EQ(server->stats().refused_origin, 2u);

  WsClient same(server->port());
  EXPECT_EQ(same.connect("/ws", "http://127.0.0.1:" + port).result(), http::status::switching_protocols);
  WsClient no_origin(server->port());
  EXPECT_EQ(no_origin.connect("/ws").result(), http::status::switching_protocols);
  EXPECT_TRUE(events_.waitOpened(2));
  EXPECT_EQ(server->stats().ws_opened, 2u);
}

TEST_F(WebServerTest, TextRoundTripThroughCallbacksAndSendText) {
  auto server = start();
  ASSERT_TRUE(server);
  WsClient client(server->port());
  ASSERT_EQ(client.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(1));
  const ClientId id = events_.opened().at(0);

  client.sendText(R"({"type":"view","free":true})");
  ASSERT_TRUE(events_.waitTexts(1));
  const auto [from, text] = events_.texts().at(0);
  EXPECT_EQ(from, id);
  EXPECT_EQ(text, R"({"type":"view","free":true})");

  server->sendText(id, "echo:" + text);
  auto [reply, ec] = client.read();
  ASSERT_FALSE(ec) << ec.message();
  EXPECT_TRUE(client.gotText());
  EXPECT_EQ(reply, R"(echo:{"type":"view","free":true})");

  server->sendBinary(id, std::string("VXL1\0\0", 6));
  std::tie(reply, ec) = client.read();
  ASSERT_FALSE(ec);
  EXPECT_FALSE(client.gotText());
  EXPECT_EQ(reply, std::string("VXL1\0\0", 6));

  server->sendText(id + 100, "nobody");  // unknown: ignored
  server->close(id, "console stopping");
  std::tie(reply, ec) = client.read();
  EXPECT_EQ(ec, websocket::error::closed);
  EXPECT_EQ(client.reason().code, websocket::close_code::normal);
  EXPECT_EQ(str(client.reason().reason), "console stopping");
  ASSERT_TRUE(events_.waitClosed(1));
  EXPECT_EQ(events_.closed().at(0), id);
}

TEST_F(WebServerTest, BroadcastReachesEveryClient) {
  auto server = start();
  ASSERT_TRUE(server);
  WsClient a(server->port());
  WsClient b(server->port());
  ASSERT_EQ(a.connect().result(), http::status::switching_protocols);
  ASSERT_EQ(b.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(2));
  server->broadcastText(R"({"type":"link","state":"connected"})");
  for (WsClient* c : {&a, &b}) {
    const auto [msg, ec] = c->read();
    ASSERT_FALSE(ec);
    EXPECT_EQ(msg, R"({"type":"link","state":"connected"})");
  }
  EXPECT_EQ(server->stats().ws_clients, 2u);
}

TEST_F(WebServerTest, BinaryFromThePageGetsAnErrorAndTheSocketStaysOpen) {
  auto server = start();
  ASSERT_TRUE(server);
  WsClient client(server->port());
  ASSERT_EQ(client.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(1));
  client.sendBinary("\x01\x02\x03");
  const auto [msg, ec] = client.read();
  ASSERT_FALSE(ec);
  EXPECT_TRUE(client.gotText());
  EXPECT_EQ(msg, R"({"type":"error","text":"binary messages are not accepted"})");
  EXPECT_EQ(server->stats().binary_refused, 1u);

  client.sendText("still here");
  ASSERT_TRUE(events_.waitTexts(1));
  EXPECT_EQ(events_.texts().at(0).second, "still here");
  EXPECT_TRUE(events_.closed().empty());
}

TEST_F(WebServerTest, OversizeMessageClosesWith1009AndOthersStillConnect) {
  WebServerConfig config;
  config.max_message_bytes = 1024;
  auto server = start(config);
  ASSERT_TRUE(server);
  WsClient big(server->port());
  ASSERT_EQ(big.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(1));
  big.sendText(std::string(1024, 'a'));  // at the limit: accepted
  ASSERT_TRUE(events_.waitTexts(1));
  big.sendRawFrameStart(100 * 1024, 1000);
  const auto [msg, ec] = big.read();
  EXPECT_EQ(ec, websocket::error::closed) << ec.message();
  EXPECT_EQ(big.reason().code, websocket::close_code::too_big);
  ASSERT_TRUE(events_.waitClosed(1));
  EXPECT_EQ(server->stats().oversize_messages, 1u);
  EXPECT_EQ(events_.texts().size(), 1u);

  WsClient next(server->port());
  ASSERT_EQ(next.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(2));
  next.sendText("hello");
  ASSERT_TRUE(events_.waitTexts(2));
  server->sendText(events_.opened().at(1), "hi");
  EXPECT_EQ(next.read().first, "hi");
}

TEST_F(WebServerTest, ClientThatDoesNotReadIsClosedOverItsQueueLimit) {
  WebServerConfig config;
  config.max_queued_bytes = 4u << 20;
  auto server = start(config);
  ASSERT_TRUE(server);
  WsClient slow(server->port());
  WsClient fast(server->port());
  ASSERT_EQ(slow.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(1));
  ASSERT_EQ(fast.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(2));
  const ClientId slow_id = events_.opened().at(0);
  const ClientId fast_id = events_.opened().at(1);

  const std::string mib(1u << 20, 'x');
  for (int i = 0; i < 200; ++i) {
    server->sendText(slow_id, mib);
    if (i % 20 == 0) server->sendText(fast_id, "tick " + std::to_string(i));
  }
  for (int i = 0; i < 200; i += 20) {
    const auto [msg, ec] = fast.read();
    ASSERT_FALSE(ec) << ec.message();
    EXPECT_EQ(msg, "tick " + std::to_string(i));
  }
  ASSERT_TRUE(events_.waitClosed(1));
  EXPECT_EQ(events_.closed().at(0), slow_id);
  const WebServerStats stats = server->stats();
  EXPECT_EQ(stats.slow_closed, 1u);
  EXPECT_EQ(stats.ws_clients, 1u);
  EXPECT_LE(stats.queued_bytes, config.max_queued_bytes);

  // The fast client still gets messages after the slow one is gone.
  server->sendText(fast_id, "after");
  EXPECT_EQ(fast.read().first, "after");
  // The slow client finds its connection ended once it reads what had reached it.
  beast::error_code ec;
  for (int i = 0; i < 200 && !ec; ++i) ec = slow.read().second;
  EXPECT_TRUE(ec);
}

TEST_F(WebServerTest, WriteWithoutProgressClosesTheClientAfterWriteTimeout) {
  WebServerConfig config;
  config.max_queued_bytes = 256u << 20;  // the queue limit is not what closes it here
  config.write_timeout = 300ms;
  auto server = start(config);
  ASSERT_TRUE(server);
  WsClient stalled(server->port());
  ASSERT_EQ(stalled.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(1));
  // Far more than the socket buffers of both ends hold: a write stops making progress.
  const std::string mib(1u << 20, 'x');
  for (int i = 0; i < 64; ++i) server->sendText(events_.opened().at(0), mib);
  ASSERT_TRUE(events_.waitClosed(1));
  EXPECT_EQ(server->stats().slow_closed, 1u);
  EXPECT_EQ(server->stats().queued_bytes, 0u);
}

TEST_F(WebServerTest, ConnectionsBeyondMaxClientsGet503) {
  WebServerConfig config;
  config.max_clients = 2;
  auto server = start(config);
  ASSERT_TRUE(server);
  auto a = std::make_unique<WsClient>(server->port());
  WsClient b(server->port());
  ASSERT_EQ(a->connect().result(), http::status::switching_protocols);
  ASSERT_EQ(b.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(2));
  const Response full = get(server->port(), "/");
  EXPECT_EQ(full.result(), http::status::service_unavailable);
  WsClient c(server->port());
  EXPECT_EQ(c.connect().result(), http::status::service_unavailable);
  EXPECT_EQ(server->stats().refused_full, 2u);

  a->stream().close(websocket::close_code::normal);
  a.reset();
  ASSERT_TRUE(events_.waitClosed(1));
  EXPECT_EQ(get(server->port(), "/").result(), http::status::ok);
}

TEST_F(WebServerTest, StopWithClientsConnectedReturnsPromptly) {
  auto server = start();
  ASSERT_TRUE(server);
  WsClient a(server->port());
  WsClient b(server->port());
  ASSERT_EQ(a.connect().result(), http::status::switching_protocols);
  ASSERT_EQ(b.connect().result(), http::status::switching_protocols);
  ASSERT_TRUE(events_.waitOpened(2));
  // An idle keep-alive HTTP connection too.
  asio::io_context io;
  beast::tcp_stream http_conn(io);
  http_conn.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server->port()));
  server->sendText(events_.opened().at(0), std::string(1u << 20, 'q'));

  const auto t0 = std::chrono::steady_clock::now();
  server->stop();
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_LT(took, 2s);
  EXPECT_EQ(events_.closed().size(), 2u);
  EXPECT_EQ(server->stats().ws_clients, 0u);
  server->stop();                     // idempotent
  server->sendText(1, "after stop");  // ignored

  beast::error_code ec;
  for (int i = 0; i < 10 && !ec; ++i) ec = b.read().second;
  EXPECT_TRUE(ec);
}

TEST(WebServerConfigTest, ValidateNamesTheBadField) {
  WebServerConfig config;
  EXPECT_TRUE(config.validate().ok());
  config.max_clients = 0;
  ASSERT_FALSE(config.validate().ok());
  EXPECT_TRUE(test::contains(config.validate().error().message, "max_clients"));
  config = {};
  config.address = "localhost:80";
  ASSERT_FALSE(config.validate().ok());
  EXPECT_TRUE(test::contains(config.validate().error().message, "address"));
  config = {};
  config.token = "a b;c";
  ASSERT_FALSE(config.validate().ok());
  EXPECT_TRUE(test::contains(config.validate().error().message, "token"));
  EXPECT_FALSE(test::contains(config.validate().error().message, "a b;c"));
  config = {};
  config.web_root = "/nonexistent/vog-www";
  config.port = 0;
  const auto server = WebServer::start(config, {});
  ASSERT_FALSE(server.ok());
  EXPECT_TRUE(test::contains(server.error().message, "web_root"));
}

}  // namespace
}  // namespace vog::console
