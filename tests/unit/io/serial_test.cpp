// Serial transport over a real pseudo-terminal (vog::mock::PtyDevice): line settings, raw mode,
// exclusive open, byte round trip, unplug/replug reconnect, missing device.

#include <gtest/gtest.h>
#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <memory>
#include <random>
#include <vector>

#include "pump.hpp"
#include "test_support.hpp"
#include "vog/io/serial.hpp"
#include "vog/mock/pty_device.hpp"

namespace vog::io {
namespace {

using test::pumpUntil;
using test::randomBytes;

struct SerialFixture : ::testing::Test {
  test::TempDir dir{"vog-serial"};
  asio::io_context io;
  std::vector<std::uint8_t> received;
  std::vector<std::int64_t> stamps;
  std::vector<DeviceHealth> states;

  std::unique_ptr<SerialTransport> makeTransport(SerialConfig config, StampClock clock = steadyStampClock()) {
    return std::make_unique<SerialTransport>(
        io, std::move(config), std::move(clock),
        [this](std::span<const std::uint8_t> bytes, std::int64_t stamp_ns) {
          received.insert(received.end(), bytes.begin(), bytes.end());
          stamps.push_back(stamp_ns);
        },
        [this](const DeviceHealth& h) { states.push_back(h); });
  }
};

TEST(SerialConfigTest, ValidateNamesKeyAndValue) {
  SerialConfig c;
  EXPECT_FALSE(c.validate("dvl.serial").ok());
  EXPECT_NE(c.validate("dvl.serial").error().message.find("dvl.serial.device_path"), std::string::npos);
  c.device_path = "/dev/ttyS0";
  EXPECT_TRUE(c.validate().ok());
  c.baud = 12345;
  ASSERT_FALSE(c.validate("dvl.serial").ok());
  EXPECT_NE(c.validate("dvl.serial").error().message.find("dvl.serial.baud 12345"), std::string::npos);
  c.baud = 9600;
  c.stop_bits = 3;
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("stop_bits"), std::string::npos);
  c.stop_bits = 1;
  c.reconnect.max_delay_ms = 1;
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("serial.reconnect.max_delay_ms"), std::string::npos);
}

TEST_F(SerialFixture, StartRejectsInvalidConfig) {
  SerialConfig c;
  c.device_path = (dir.path() / "tty").string();
  c.data_bits = 9;
  auto t = makeTransport(c);
  Status s = t->start();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("data_bits"), std::string::npos);
  EXPECT_EQ(t->health().state, LinkState::kDisconnected);
}

TEST_F(SerialFixture, AppliesLineSettingsRawModeAndExclusiveOpen) {
  auto dev = mock::PtyDevice::create(dir.path() / "dvl");
  ASSERT_TRUE(dev.ok()) << dev.error().message;
  SerialConfig c;
  c.device_path = (*dev)->linkPath().string();
  c.baud = 9600;
  c.stop_bits = 2;
  auto t = makeTransport(c);
  ASSERT_TRUE(t->start().ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().state == LinkState::kConnected; })) << t->health().reason;

  auto tio = (*dev)->lineSettings();
  ASSERT_TRUE(tio.ok()) << tio.error().message;
  EXPECT_EQ(::cfgetispeed(&*tio), B9600);
  EXPECT_EQ(::cfgetospeed(&*tio), B9600);
  EXPECT_FALSE(tio->c_cflag & PARENB);
  EXPECT_EQ(tio->c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
  EXPECT_TRUE(tio->c_cflag & CSTOPB);
  EXPECT_TRUE(tio->c_cflag & CREAD);
  EXPECT_FALSE(tio->c_lflag & (ICANON | ECHO | ISIG));
  EXPECT_FALSE(tio->c_iflag & (ICRNL | IXON));
  EXPECT_FALSE(tio->c_oflag & OPOST);
  auto excl = (*dev)->exclusive();
  ASSERT_TRUE(excl.ok()) << excl.error().message;
  EXPECT_TRUE(*excl);
}

// Parity: applied where the line accepts it; where the driver refuses it (this machine's
// pseudo-terminals reject some PARENB/CS7 combinations with EINVAL) the transport stays
// disconnected and names the refused option instead of running with the wrong framing.
TEST_F(SerialFixture, ParityIsAppliedOrTheRefusalIsNamed) {
  for (const Parity parity : {Parity::kEven, Parity::kOdd}) {
    auto dev = mock::PtyDevice::create(dir.path() / "depth");
    ASSERT_TRUE(dev.ok()) << dev.error().message;
    SerialConfig c;
    c.device_path = (*dev)->linkPath().string();
    c.parity = parity;
    auto t = makeTransport(c);
    ASSERT_TRUE(t->start().ok());
    ASSERT_TRUE(pumpUntil(io, [&] { return t->health().state == LinkState::kConnected || t->health().errors >= 1; }));
    if (t->health().state == LinkState::kConnected) {
      auto tio = (*dev)->lineSettings();
      ASSERT_TRUE(tio.ok());
      EXPECT_TRUE(tio->c_cflag & PARENB);
      EXPECT_EQ((tio->c_cflag & PARODD) != 0, parity == Parity::kOdd);
      EXPECT_TRUE(tio->c_iflag & INPCK);
    } else {
      EXPECT_NE(t->health().last_error.find("parity"), std::string::npos) << t->health().last_error;
    }
  }
}

TEST_F(SerialFixture, MovesEveryByteBothWaysUnaltered) {
  auto dev = mock::PtyDevice::create(dir.path() / "dvl");
  ASSERT_TRUE(dev.ok()) << dev.error().message;
  SerialConfig c;
  c.device_path = (*dev)->linkPath().string();
  test::SteppingClock clock;
  auto t = makeTransport(c, clock);
  ASSERT_TRUE(t->start().ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().state == LinkState::kConnected; })) << t->health().reason;

  // Every byte value, including CR, LF, XON/XOFF and ^C that a cooked line would alter.
  const std::vector<std::uint8_t> down = randomBytes(64 * 1024, 7);
  (*dev)->send(down);
  ASSERT_TRUE(pumpUntil(io, [&] { return received.size() >= down.size(); })) << received.size();
  EXPECT_EQ(received, down);
  EXPECT_EQ(t->health().bytes_rx, down.size());
  // Stamps come from the injected clock, one reading per delivered chunk.
  ASSERT_FALSE(stamps.empty());
  EXPECT_EQ(stamps.front(), 1'000'000'000);
  for (std::size_t i = 1; i < stamps.size(); ++i) EXPECT_EQ(stamps[i] - stamps[i - 1], 1'000'000);
  EXPECT_EQ(t->health().last_data_stamp_ns, stamps.back());

  const std::vector<std::uint8_t> up = randomBytes(5000, 8);
  ASSERT_TRUE(t->write(up).ok());
  ASSERT_TRUE(
      pumpUntil(io, [&] { return (*dev)->hostBytes().size() >= up.size() && t->health().bytes_tx >= up.size(); }));
  EXPECT_EQ((*dev)->hostBytes(), up);
  EXPECT_EQ(t->health().bytes_tx, up.size());
}

TEST_F(SerialFixture, ReconnectsWhenDeviceIsUnpluggedAndReturns) {
  auto dev = mock::PtyDevice::create(dir.path() / "dvl");
  ASSERT_TRUE(dev.ok()) << dev.error().message;
  SerialConfig c;
  c.device_path = (*dev)->linkPath().string();
  c.reconnect.initial_delay_ms = 5;
  c.reconnect.max_delay_ms = 20;
  auto t = makeTransport(c);
  ASSERT_TRUE(t->start().ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().state == LinkState::kConnected; }));
  const std::vector<std::uint8_t> first = {1, 2, 3};
  (*dev)->send(first);
  ASSERT_TRUE(pumpUntil(io, [&] { return received.size() == 3; }));

  ASSERT_TRUE((*dev)->unplug().ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().state != LinkState::kConnected; }));
  // The first state after the loss names the failed read.
  const auto lost = std::find_if(states.begin(), states.end(),
                                 [](const DeviceHealth& h) { return h.state == LinkState::kDisconnected; });
  ASSERT_NE(lost, states.end());
  EXPECT_NE(lost->reason.find("read"), std::string::npos) << lost->reason;
  EXPECT_FALSE(t->write(first).ok());
  // While the device is away every attempt fails with the missing path named.
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().reason.find("No such file") != std::string::npos; }))
      << t->health().reason;
  EXPECT_NE(t->health().reason.find(c.device_path), std::string::npos);

  ASSERT_TRUE((*dev)->replug().ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().state == LinkState::kConnected; })) << t->health().reason;
  EXPECT_EQ(t->health().connects, 2u);
  const std::vector<std::uint8_t> second = {4, 5, 6, 7};
  (*dev)->send(second);
  ASSERT_TRUE(pumpUntil(io, [&] { return received.size() == 7; }));
  EXPECT_EQ(received, (std::vector<std::uint8_t>{1, 2, 3, 4, 5, 6, 7}));

  // The state history went connected -> disconnected -> connecting ... -> connected.
  bool saw_disconnected = false;
  bool saw_connecting_after = false;
  for (const DeviceHealth& h : states) {
    if (h.state == LinkState::kDisconnected && h.connects == 1) saw_disconnected = true;
    if (saw_disconnected && h.state == LinkState::kConnecting) saw_connecting_after = true;
  }
  EXPECT_TRUE(saw_disconnected);
  EXPECT_TRUE(saw_connecting_after);
}

TEST_F(SerialFixture, MissingDeviceIsReportedAndRetried) {
  SerialConfig c;
  c.device_path = (dir.path() / "absent").string();
  c.reconnect.initial_delay_ms = 2;
  c.reconnect.max_delay_ms = 4;
  auto t = makeTransport(c);
  ASSERT_TRUE(t->start().ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().errors >= 3; }));
  EXPECT_EQ(t->health().state == LinkState::kConnected, false);
  EXPECT_NE(t->health().last_error.find(c.device_path), std::string::npos);
  EXPECT_EQ(t->health().connects, 0u);
}

TEST_F(SerialFixture, RegularFileIsRejectedAsNotATerminal) {
  const auto path = dir.path() / "plain";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fclose(f);
  }
  SerialConfig c;
  c.device_path = path.string();
  auto t = makeTransport(c);
  ASSERT_TRUE(t->start().ok());
  ASSERT_TRUE(pumpUntil(io, [&] { return t->health().errors >= 1; }));
  EXPECT_NE(t->health().last_error.find("not a terminal"), std::string::npos) << t->health().last_error;
}

TEST(ReconnectBackoffTest, DoublesUpToMaxAndResets) {
  ReconnectConfig c;
  c.initial_delay_ms = 10;
  c.max_delay_ms = 50;
  ReconnectBackoff b(c);
  EXPECT_EQ(b.nextDelay().count(), 10);
  EXPECT_EQ(b.nextDelay().count(), 20);
  EXPECT_EQ(b.nextDelay().count(), 40);
  EXPECT_EQ(b.nextDelay().count(), 50);
  EXPECT_EQ(b.nextDelay().count(), 50);
  b.reset();
  EXPECT_EQ(b.nextDelay().count(), 10);
}

}  // namespace
}  // namespace vog::io
