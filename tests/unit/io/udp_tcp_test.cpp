// UDP receiver/sender and TCP client with reconnect, on loopback.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <memory>
#include <random>
#include <vector>

#include "pump.hpp"
#include "vog/io/tcp_client.hpp"
#include "vog/io/udp.hpp"

namespace vog::io {
namespace {

using test::pumpUntil;
using test::randomBytes;

TEST(UdpTest, DeliversWholeDatagramsWithInjectedStamps) {
  asio::io_context io;
  std::vector<std::vector<std::uint8_t>> got;
  std::vector<std::int64_t> stamps;
  test::SteppingClock clock;
  UdpReceiver rx(io, UdpReceiverConfig{}, clock, [&](std::span<const std::uint8_t> d, std::int64_t stamp_ns) {
    got.emplace_back(d.begin(), d.end());
    stamps.push_back(stamp_ns);
  });
  ASSERT_TRUE(rx.start().ok());
  ASSERT_EQ(rx.health().state, LinkState::kConnected) << rx.health().reason;
  ASSERT_NE(rx.localPort(), 0);

  UdpSenderConfig sc;
  sc.port = rx.localPort();
  UdpSender tx(io, sc);
  ASSERT_TRUE(tx.open().ok());
  // Sizes include an empty datagram and a 96 x 512 DIDSON frame (49152 bytes) in one datagram.
  const std::vector<std::size_t> sizes = {1, 0, 1400, 49152, 65507};
  std::vector<std::vector<std::uint8_t>> sent;
  for (std::size_t i = 0; i < sizes.size(); ++i) {
    sent.push_back(randomBytes(sizes[i], i));
    ASSERT_TRUE(tx.send(sent.back()).ok()) << tx.health().last_error;
  }
  ASSERT_TRUE(pumpUntil(io, [&] { return got.size() == sent.size(); }));
  EXPECT_EQ(got, sent);
  EXPECT_EQ(stamps,
            (std::vector<std::int64_t>{1'000'000'000, 1'001'000'000, 1'002'000'000, 1'003'000'000, 1'004'000'000}));
  EXPECT_EQ(rx.health().frames_rx, sent.size());
  EXPECT_EQ(tx.health().frames_tx, sent.size());
  EXPECT_EQ(rx.health().errors, 0u);
}

TEST(UdpTest, OversizedDatagramIsCountedNotDeliveredTruncated) {
  asio::io_context io;
  std::vector<std::size_t> got;
  UdpReceiverConfig rc;
  rc.max_datagram_bytes = 100;
  UdpReceiver rx(io, rc, steadyStampClock(),
                 [&](std::span<const std::uint8_t> d, std::int64_t) { got.push_back(d.size()); });
  ASSERT_TRUE(rx.start().ok());
  UdpSenderConfig sc;
  sc.port = rx.localPort();
  UdpSender tx(io, sc);
  ASSERT_TRUE(tx.open().ok());
  ASSERT_TRUE(tx.send(randomBytes(101, 1)).ok());
  ASSERT_TRUE(tx.send(randomBytes(100, 2)).ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return got.size() == 1; }));
  EXPECT_EQ(got, (std::vector<std::size_t>{100}));
  EXPECT_EQ(rx.health().errors, 1u);
  EXPECT_NE(rx.health().last_error.find("larger than 100"), std::string::npos) << rx.health().last_error;
}

TEST(UdpTest, ConfigErrorsNameTheKey) {
  UdpReceiverConfig rc;
  rc.bind_address = "localhost.invalid";
  ASSERT_FALSE(rc.validate("sonar.udp").ok());
  EXPECT_NE(rc.validate("sonar.udp").error().message.find("sonar.udp.bind_address"), std::string::npos);
  UdpSenderConfig sc;
  ASSERT_FALSE(sc.validate().ok());
  EXPECT_NE(sc.validate().error().message.find("udp_sender.port"), std::string::npos);
  asio::io_context io;
  UdpSender tx(io, sc);
  EXPECT_FALSE(tx.open().ok());
  EXPECT_FALSE(tx.send(randomBytes(3, 1)).ok());
}

// A loopback TCP server for the client tests: accepts one connection at a time.
struct TestServer {
  explicit TestServer(asio::io_context& io)
      : acceptor(io, asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0)) {}
  void acceptOne() {
    acceptor.async_accept([this](const std::error_code& ec, asio::ip::tcp::socket s) {
      if (ec) return;
      peer = std::make_unique<asio::ip::tcp::socket>(std::move(s));
      ++accepted;
      readMore();
    });
  }
  void readMore() {
    peer->async_read_some(asio::buffer(buffer), [this](const std::error_code& ec, std::size_t n) {
      if (ec) return;
      received.insert(received.end(), buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
      readMore();
    });
  }
  std::uint16_t port() const { return acceptor.local_endpoint().port(); }
  asio::ip::tcp::acceptor acceptor;
  std::unique_ptr<asio::ip::tcp::socket> peer;
  std::array<std::uint8_t, 4096> buffer{};
  std::vector<std::uint8_t> received;
  int accepted = 0;
};

TEST(TcpClientTest, RoundTripAndReconnectAfterServerCloses) {
  asio::io_context io;
  TestServer server(io);
  server.acceptOne();
  TcpClientConfig c;
  c.port = server.port();
  c.reconnect.initial_delay_ms = 5;
  c.reconnect.max_delay_ms = 20;
  std::vector<std::uint8_t> got;
  std::vector<DeviceHealth> states;
  TcpClient client(
      io, c, steadyStampClock(),
      [&](std::span<const std::uint8_t> b, std::int64_t) { got.insert(got.end(), b.begin(), b.end()); },
      [&](const DeviceHealth& h) { states.push_back(h); });
  ASSERT_TRUE(client.start().ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return client.health().state == LinkState::kConnected && server.peer; }));

  const auto up = randomBytes(20000, 3);
  ASSERT_TRUE(client.write(up).ok());
  const auto down = randomBytes(30000, 4);
  asio::write(*server.peer, asio::buffer(down));
  ASSERT_TRUE(pumpUntil(io, [&] { return got.size() == down.size() && server.received.size() == up.size(); }));
  EXPECT_EQ(got, down);
  EXPECT_EQ(server.received, up);

  // The vehicle side drops the connection: the client reports it and reconnects by itself.
  server.peer->close();
  server.received.clear();
  server.acceptOne();
  ASSERT_TRUE(pumpUntil(io, [&] { return server.accepted == 2 && client.health().state == LinkState::kConnected; }));
  EXPECT_EQ(client.health().connects, 2u);
  const auto lost = std::find_if(states.begin(), states.end(),
                                 [](const DeviceHealth& h) { return h.state == LinkState::kDisconnected; });
  ASSERT_NE(lost, states.end());
  EXPECT_NE(lost->reason.find("closed by peer"), std::string::npos) << lost->reason;
  const std::vector<std::uint8_t> again = {'$', 'B', 'P'};
  ASSERT_TRUE(client.write(again).ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return server.received.size() == 3; }));
  EXPECT_EQ(server.received, again);
}

TEST(TcpClientTest, RefusedConnectionIsReportedAndRetried) {
  asio::io_context io;
  std::uint16_t port = 0;
  {
    // A port that was just free: nothing listens there now.
    asio::ip::tcp::acceptor probe(io, asio::ip::tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
    port = probe.local_endpoint().port();
  }
  TcpClientConfig c;
  c.port = port;
  c.reconnect.initial_delay_ms = 2;
  c.reconnect.max_delay_ms = 4;
  TcpClient client(io, c, steadyStampClock(), {});
  ASSERT_TRUE(client.start().ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return client.health().errors >= 3; }));
  EXPECT_NE(client.health().state, LinkState::kConnected);
  EXPECT_NE(client.health().last_error.find("refused"), std::string::npos) << client.health().last_error;
  EXPECT_FALSE(client.write(std::vector<std::uint8_t>{1}).ok());
  client.stop();
  EXPECT_EQ(client.health().state, LinkState::kDisconnected);
  EXPECT_EQ(client.health().reason, "stopped");
}

}  // namespace
}  // namespace vog::io
