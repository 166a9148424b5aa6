// CAN read/write loop over a Unix-domain SOCK_SEQPACKET socket pair and socket path (the same
// fd path a PF_CAN socket takes), and the Modbus client against a libmodbus TCP server.

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstring>
#include <memory>
#include <vector>

#include "pump.hpp"
#include "test_support.hpp"
#include "vog/io/can.hpp"
#include "vog/io/modbus_client.hpp"
#include "vog/mock/aux_board.hpp"

namespace vog::io {
namespace {

using test::pumpUntil;

can_frame makeFrame(std::uint32_t id, std::vector<std::uint8_t> data) {
  can_frame f{};
  f.can_id = id;
  f.len = static_cast<std::uint8_t>(data.size());
  std::memcpy(f.data, data.data(), data.size());
  return f;
}

bool sameFrame(const can_frame& a, const can_frame& b) {
  return a.can_id == b.can_id && a.len == b.len && std::memcmp(a.data, b.data, a.len) == 0;
}

struct CanPair : ::testing::Test {
  void SetUp() override { ASSERT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, fds), 0); }
  void TearDown() override {
    if (fds[1] >= 0) ::close(fds[1]);
  }
  std::unique_ptr<CanTransport> adopt(std::vector<CanFilter> filters) {
    auto t =
        CanTransport::adopt(io, fds[0], std::move(filters), clock, [this](const can_frame& f, std::int64_t stamp_ns) {
          got.push_back(f);
          stamps.push_back(stamp_ns);
        });
    fds[0] = -1;
    return t;
  }
  void peerSend(const void* record, std::size_t n) { ASSERT_EQ(::send(fds[1], record, n, 0), static_cast<ssize_t>(n)); }
  int fds[2] = {-1, -1};
  asio::io_context io;
  test::SteppingClock clock;
  std::vector<can_frame> got;
  std::vector<std::int64_t> stamps;
};

TEST_F(CanPair, FiltersLikeSocketCanAndRejectsMalformedRecords) {
  // IMU frames 0x100..0x10F pass; one extended id passes by exact match with the EFF flag.
  auto t = adopt({CanFilter{0x100, 0x7F0}, CanFilter{0x18FF0001u | CAN_EFF_FLAG, CAN_EFF_FLAG | CAN_EFF_MASK}});
  ASSERT_TRUE(t->start().ok());
  ASSERT_EQ(t->health().state, LinkState::kConnected);

  const can_frame pass1 = makeFrame(0x105, {1, 2, 3, 4, 5, 6, 7, 8});
  const can_frame drop1 = makeFrame(0x205, {9});
  const can_frame pass2 = makeFrame(0x18FF0001u | CAN_EFF_FLAG, {0xAA, 0xBB});
  const can_frame drop2 = makeFrame(0x18FF0001u, {0xCC});  // same bits, but a standard-frame id
  can_frame too_long = makeFrame(0x101, {1});
  too_long.len = 9;
  const can_frame error_frame = makeFrame(CAN_ERR_FLAG | 0x4, {0, 0, 0, 0, 0, 0, 0, 0});
  const std::uint8_t short_record[8] = {0x01, 0x01, 0, 0, 1, 0, 0, 0};
  peerSend(&pass1, sizeof(pass1));
  peerSend(&drop1, sizeof(drop1));
  peerSend(short_record, sizeof(short_record));
  peerSend(&too_long, sizeof(too_long));
  peerSend(&error_frame, sizeof(error_frame));
  peerSend(&drop2, sizeof(drop2));
  peerSend(&pass2, sizeof(pass2));
  ASSERT_TRUE(pumpUntil(io, [&] { return got.size() == 2 && t->health().errors == 3; }))
      << got.size() << " " << t->health().errors;
  EXPECT_TRUE(sameFrame(got[0], pass1));
  EXPECT_TRUE(sameFrame(got[1], pass2));
  EXPECT_EQ(t->framesFiltered(), 2u);
  EXPECT_EQ(t->health().frames_rx, 4u);  // valid frames, filtered or not
  EXPECT_LT(stamps[0], stamps[1]);

  // Writes arrive on the peer as whole 16-byte records.
  const can_frame out = makeFrame(0x120, {0x10, 0x20, 0x30});
  ASSERT_TRUE(t->write(out).ok());
  can_frame bad = out;
  bad.len = 12;
  EXPECT_FALSE(t->write(bad).ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().frames_tx == 1; }));
  can_frame echoed{};
  ASSERT_EQ(::recv(fds[1], &echoed, sizeof(echoed), MSG_DONTWAIT), static_cast<ssize_t>(sizeof(can_frame)));
  EXPECT_TRUE(sameFrame(echoed, out));
}

TEST_F(CanPair, EmptyFilterListAcceptsAllAndHangupIsFinal) {
  auto t = adopt({});
  ASSERT_TRUE(t->start().ok());
  for (std::uint32_t id = 0; id < 50; ++id) {
    const can_frame f = makeFrame(id, {static_cast<std::uint8_t>(id)});
    peerSend(&f, sizeof(f));
  }
  ASSERT_TRUE(pumpUntil(io, [&] { return got.size() == 50; }));
  for (std::uint32_t id = 0; id < 50; ++id) EXPECT_EQ(got[id].can_id, id);
  ::close(fds[1]);
  fds[1] = -1;
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().state == LinkState::kDisconnected; }));
  EXPECT_NE(t->health().reason.find("peer closed"), std::string::npos) << t->health().reason;
}

TEST(CanConfigTest, ExactlyOneEndpoint) {
  CanConfig c;
  ASSERT_FALSE(c.validate("imu.can").ok());
  EXPECT_NE(c.validate("imu.can").error().message.find("imu.can"), std::string::npos);
  c.interface = "can0";
  EXPECT_TRUE(c.validate().ok());
  c.unix_seqpacket = "/run/vog/imu.sock";
  EXPECT_FALSE(c.validate().ok());
  c.unix_seqpacket.clear();
  c.interface = "averyveryverylongname";
  EXPECT_FALSE(c.validate().ok());
}

TEST(CanSocketPathTest, ConnectsToServerPathAndReconnectsWhenItReturns) {
  test::TempDir dir("vog-can");
  const std::string path = (dir.path() / "imu.sock").string();
  auto listen_on = [&path] {
    const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
    ::unlink(path.c_str());
    EXPECT_EQ(::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)), 0);
    EXPECT_EQ(::listen(fd, 1), 0);
    return fd;
  };
  asio::io_context io;
  std::vector<can_frame> got;
  CanConfig c;
  c.unix_seqpacket = path;
  c.reconnect.initial_delay_ms = 2;
  c.reconnect.max_delay_ms = 10;
  CanTransport t(io, c, steadyStampClock(), [&](const can_frame& f, std::int64_t) { got.push_back(f); });
  ASSERT_TRUE(t.start().ok());
  // No server yet: retried, with the path named.
  ASSERT_TRUE(pumpUntil(io, [&] { return t.health().errors >= 2; }));
  EXPECT_NE(t.health().last_error.find(path), std::string::npos);

  int server = listen_on();
  ASSERT_TRUE(pumpUntil(io, [&] { return t.health().state == LinkState::kConnected; })) << t.health().reason;
  int conn = ::accept(server, nullptr, nullptr);
  ASSERT_GE(conn, 0);
  const can_frame f1 = makeFrame(0x100, {1});
  ASSERT_EQ(::send(conn, &f1, sizeof(f1), 0), static_cast<ssize_t>(sizeof(f1)));
  ASSERT_TRUE(pumpUntil(io, [&] { return got.size() == 1; }));

  // The device goes away (socket closed, path removed) and comes back at the same path.
  ::close(conn);
  ::close(server);
  ::unlink(path.c_str());
  ASSERT_TRUE(pumpUntil(io, [&] { return t.health().state != LinkState::kConnected; }));
  server = listen_on();
  ASSERT_TRUE(pumpUntil(io, [&] { return t.health().state == LinkState::kConnected; })) << t.health().reason;
  conn = ::accept(server, nullptr, nullptr);
  ASSERT_GE(conn, 0);
  const can_frame f2 = makeFrame(0x101, {2, 3});
  ASSERT_EQ(::send(conn, &f2, sizeof(f2), 0), static_cast<ssize_t>(sizeof(f2)));
  ASSERT_TRUE(pumpUntil(io, [&] { return got.size() == 2; }));
  EXPECT_TRUE(sameFrame(got[1], f2));
  EXPECT_EQ(t.health().connects, 2u);
  ::close(conn);
  ::close(server);
}

TEST(ModbusClientTest, ReadsAndWritesRegistersOfALibmodbusServer) {
  auto board = mock::AuxBoardMock::create();
  ASSERT_TRUE(board.ok()) << board.error().message;
  for (int i = 0; i < 64; ++i) {
    ASSERT_TRUE((*board)->setInputRegister(i, static_cast<std::uint16_t>(1000 + i)).ok());
    ASSERT_TRUE((*board)->setHoldingRegister(i, static_cast<std::uint16_t>(0xA000 + i)).ok());
  }
  ModbusConfig c;
  c.tcp_address = "127.0.0.1";
  c.tcp_port = (*board)->port();
  c.response_timeout_ms = 200;
  ModbusClient client(c);
  auto input = client.readInputRegisters(10, 5);
  ASSERT_TRUE(input.ok()) << input.error().message;
  EXPECT_EQ(*input, (std::vector<std::uint16_t>{1010, 1011, 1012, 1013, 1014}));
  auto holding = client.readHoldingRegisters(0, 64);
  ASSERT_TRUE(holding.ok()) << holding.error().message;
  for (int i = 0; i < 64; ++i) EXPECT_EQ((*holding)[static_cast<std::size_t>(i)], 0xA000 + i);
  ASSERT_TRUE(client.writeRegister(3, 0x1234).ok());
  EXPECT_EQ(*(*board)->holdingRegister(3), 0x1234);

  // Illegal address: a Modbus exception reply, the link stays up.
  auto out_of_table = client.readInputRegisters(60, 10);
  ASSERT_FALSE(out_of_table.ok());
  EXPECT_NE(out_of_table.error().message.find("60+10"), std::string::npos) << out_of_table.error().message;
  EXPECT_EQ(client.health().state, LinkState::kConnected);
  EXPECT_FALSE(client.readInputRegisters(0, 126).ok());  // over the 125-register limit, not sent
  EXPECT_EQ(client.health().connects, 1u);
}

TEST(ModbusClientTest, EveryFaultIsAnErrorAndTheNextReadRecovers) {
  auto board = mock::AuxBoardMock::create();
  ASSERT_TRUE(board.ok()) << board.error().message;
  ASSERT_TRUE((*board)->setInputRegister(0, 4242).ok());
  ModbusConfig c;
  c.tcp_address = "127.0.0.1";
  c.tcp_port = (*board)->port();
  c.response_timeout_ms = 100;
  ModbusClient client(c);
  ASSERT_TRUE(client.readInputRegisters(0, 1).ok());
  for (const mock::Fault fault :
       {mock::Fault::kDropout, mock::Fault::kTruncate, mock::Fault::kGarbage, mock::Fault::kBadChecksum}) {
    (*board)->faults().inject(fault);
    auto faulty = client.readInputRegisters(0, 1);
    EXPECT_FALSE(faulty.ok()) << "fault " << static_cast<int>(fault) << " delivered a value";
    auto next = client.readInputRegisters(0, 1);
    ASSERT_TRUE(next.ok()) << "after fault " << static_cast<int>(fault) << ": " << next.error().message;
    EXPECT_EQ((*next)[0], 4242);
  }
  // The board disappears (listener and connections closed) and returns on the same port.
  (*board)->disappear();
  auto gone = client.readInputRegisters(0, 1);
  EXPECT_FALSE(gone.ok());
  EXPECT_EQ(client.health().state, LinkState::kDisconnected);
  EXPECT_FALSE(client.connect().ok());
  ASSERT_TRUE((*board)->reappear().ok());
  auto back = client.readInputRegisters(0, 1);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ((*back)[0], 4242);
  EXPECT_EQ(client.health().state, LinkState::kConnected);
}

TEST(ModbusConfigTest, ValidateNamesKey) {
  ModbusConfig c;
  ASSERT_FALSE(c.validate("aux").ok());
  c.tcp_address = "127.0.0.1";
  c.slave_id = 300;
  ASSERT_FALSE(c.validate("aux").ok());
  EXPECT_NE(c.validate("aux").error().message.find("aux.slave_id"), std::string::npos);
  c.slave_id = 1;
  c.rtu_device = "/dev/ttyS1";
  EXPECT_FALSE(c.validate().ok());
  c.tcp_address.clear();
  c.rtu_baud = 1234;
  ASSERT_FALSE(c.validate("aux").ok());
  EXPECT_NE(c.validate("aux").error().message.find("aux.rtu.baud"), std::string::npos);
}

}  // namespace
}  // namespace vog::io
