// DVL and depth mocks on pseudo-terminals, read back through the real serial transport and the
// real codecs, with every fault kind and an unplug/replug.

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>

#include "pump.hpp"
#include "test_support.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/io/serial.hpp"
#include "vog/mock/serial_devices.hpp"

namespace vog::mock {
namespace {

using test::pumpUntil;

dvl::DvlEnsemble ensemble(std::uint32_t number) {
  dvl::DvlEnsemble e;
  e.fixed.n_beams = 4;
  e.fixed.n_cells = 0;
  e.fixed.coordinate_transform = 0x08;  // instrument coordinates
  e.fixed.coordinate_frame = dvl::CoordinateFrame::kInstrument;
  e.variable.ensemble_number = number;
  e.variable.clock = dvl::DvlClock{2026, 11, 21, 12, 0, static_cast<int>(number % 60), 0};
  e.variable.sound_speed_mps = 1500;
  e.variable.heading_deg = 0.5 * number;
  e.variable.pitch_deg = 1.25;
  e.variable.roll_deg = -0.75;
  e.variable.temperature_c = 12.5;
  dvl::DvlBottomTrack bt;
  bt.velocity_mps = {-0.001 * number, 0.2, -0.01, 0.002};
  bt.velocity_valid = {true, true, true, true};
  bt.range_m = {3.5, 3.6, 3.4, 3.5};
  e.bottom_track = bt;
  return e;
}

struct SerialRig {
  explicit SerialRig(const std::string& path, unsigned baud = 115200) {
    io::SerialConfig c;
    c.device_path = path;
    c.baud = baud;
    c.reconnect.initial_delay_ms = 5;
    c.reconnect.max_delay_ms = 20;
    transport = std::make_unique<io::SerialTransport>(ioc, c, io::steadyStampClock(),
                                                      [this](std::span<const std::uint8_t> b, std::int64_t stamp_ns) {
                                                        if (on_bytes) on_bytes(b, stamp_ns);
                                                      });
  }
  bool connected() const { return transport->health().state == io::LinkState::kConnected; }
  asio::io_context ioc;
  std::function<void(std::span<const std::uint8_t>, std::int64_t)> on_bytes;
  std::unique_ptr<io::SerialTransport> transport;
};

TEST(DvlMockTest, Pd0ThroughSerialAndDecoderWithEveryFault) {
  test::TempDir dir("vog-dvl");
  auto dvl = DvlMock::create(dir.path() / "dvl", 7);
  ASSERT_TRUE(dvl.ok()) << dvl.error().message;
  SerialRig rig((*dvl)->pty().linkPath().string());
  codec::StreamDecoder<dvl::Pd0Codec> decoder;
  std::map<std::uint32_t, dvl::DvlEnsemble> got;
  rig.on_bytes = [&](std::span<const std::uint8_t> b, std::int64_t stamp_ns) {
    decoder.feed(b);
    while (auto e = decoder.next()) {
      e->stamp_ns = stamp_ns;
      got[e->variable.ensemble_number] = *e;
    }
  };
  ASSERT_TRUE(rig.transport->start().ok());
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return rig.connected(); }));

  // 1-2 clean, 3 garbage before, 4 clean, 5 truncated, 6-7 clean, 8 bad checksum, 9 clean,
  // 10 dropped, 11-12 clean.
  const std::map<std::uint32_t, Fault> faults = {
      {3, Fault::kGarbage}, {5, Fault::kTruncate}, {8, Fault::kBadChecksum}, {10, Fault::kDropout}};
  for (std::uint32_t n = 1; n <= 12; ++n) {
    if (auto f = faults.find(n); f != faults.end()) (*dvl)->faults().inject(f->second);
    ASSERT_TRUE((*dvl)->sendPd0(ensemble(n)).ok());
  }
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return got.count(12) == 1; })) << got.size();
  EXPECT_EQ((*dvl)->faults().applied(), (std::array<std::uint64_t, kFaultKinds>{1, 1, 1, 1}));
  // Never a damaged ensemble: truncated, bad-checksum and dropped ones are absent...
  EXPECT_EQ(got.count(5), 0u);
  EXPECT_EQ(got.count(8), 0u);
  EXPECT_EQ(got.count(10), 0u);
  // ...the one after line noise and every clean one is there. The ensemble right after a
  // truncated one may be swallowed by the resynchronisation; no other.
  for (std::uint32_t n : {1u, 2u, 3u, 4u, 7u, 9u, 11u, 12u}) EXPECT_EQ(got.count(n), 1u) << "ensemble " << n;
  EXPECT_GE(decoder.stats().bad_checksum, 1u);
  EXPECT_GT(decoder.stats().garbage_bytes, 0u);
  // And what is delivered is what was sent (to wire resolution).
  for (const auto& [n, e] : got) {
    ASSERT_TRUE(e.bottom_track.has_value());
    EXPECT_NEAR(e.bottom_track->velocity_mps[0], -0.001 * n, 1e-3);
    EXPECT_NEAR(e.variable.heading_deg, 0.5 * n, 0.01);
    EXPECT_EQ(e.fixed.coordinate_frame, dvl::CoordinateFrame::kInstrument);
  }

  // The DVL's USB adapter is pulled and plugged back: the link recovers by itself.
  ASSERT_TRUE((*dvl)->pty().unplug().ok());
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return !rig.connected(); }));
  (*dvl)->pty().send(std::vector<std::uint8_t>{0x7F});  // nothing reaches a pulled cable
  ASSERT_TRUE((*dvl)->pty().replug().ok());
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return rig.connected(); })) << rig.transport->health().reason;
  decoder.reset();  // a partial ensemble from before the unplug must not join the new stream
  ASSERT_TRUE((*dvl)->sendPd0(ensemble(13)).ok());
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return got.count(13) == 1; }));
  EXPECT_EQ(rig.transport->health().connects, 2u);
}

TEST(DvlMockTest, Pd6LinesThroughSerial) {
  test::TempDir dir("vog-pd6");
  auto dvl = DvlMock::create(dir.path() / "dvl");
  ASSERT_TRUE(dvl.ok());
  SerialRig rig((*dvl)->pty().linkPath().string());
  codec::StreamDecoder<dvl::Pd6Codec> decoder;
  std::vector<dvl::Pd6Velocity> got;
  rig.on_bytes = [&](std::span<const std::uint8_t> b, std::int64_t) {
    decoder.feed(b);
    while (auto s = decoder.next()) {
      if (auto* v = std::get_if<dvl::Pd6Velocity>(&*s)) got.push_back(*v);
    }
  };
  ASSERT_TRUE(rig.transport->start().ok());
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return rig.connected(); }));
  for (int i = 0; i < 4; ++i) {
    if (i == 1) (*dvl)->faults().inject(Fault::kBadChecksum);
    if (i == 2) (*dvl)->faults().inject(Fault::kGarbage);
    dvl::Pd6Velocity v;
    v.frame = dvl::CoordinateFrame::kInstrument;
    v.velocity_mps = {0.001 * i, 0.2, 0.0};
    v.component_valid = {true, true, true};
    v.has_error_velocity = true;
    v.valid = true;
    (*dvl)->sendPd6(v);
  }
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return got.size() == 3; }));
  EXPECT_NEAR(got[0].velocity_mps[0], 0.000, 1e-9);
  EXPECT_NEAR(got[1].velocity_mps[0], 0.002, 1e-9);  // 1 had its status letter damaged
  EXPECT_NEAR(got[2].velocity_mps[0], 0.003, 1e-9);
  EXPECT_TRUE(got[1].valid);
}

TEST(DepthMockTest, PolledAndContinuousRepliesWithEveryFault) {
  test::TempDir dir("vog-depth");
  auto mock = DepthMock::create(dir.path() / "depth", 1, 3);
  ASSERT_TRUE(mock.ok()) << mock.error().message;
  SerialRig rig((*mock)->pty().linkPath().string(), 9600);
  codec::StreamDecoder<depth::DigiquartzCodec> decoder;
  std::vector<double> values;
  rig.on_bytes = [&](std::span<const std::uint8_t> b, std::int64_t) {
    decoder.feed(b);
    while (auto m = decoder.next()) {
      if (m->kind == depth::DigiquartzMessage::Kind::kPressure) values.push_back(m->value);
    }
  };
  ASSERT_TRUE(rig.transport->start().ok());
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return rig.connected(); }));
  auto command = [&](const std::string& c) {
    const std::string line = depth::encodeCommand(1, 0, c);
    ASSERT_TRUE(rig.transport->write(std::vector<std::uint8_t>(line.begin(), line.end())).ok());
  };

  // A poll before the sensor has any reading is answered with the first reading when it comes, not
  // with a pressure nobody gave (a zero reads as 10 m above the surface).
  command("P3");
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return (*mock)->commandsReceived() == 1; }));
  EXPECT_TRUE(values.empty());
  (*mock)->setPressure(14.6963);
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return values.size() == 1; }));
  EXPECT_NEAR(values[0], 14.6963, 1e-9);
  values.clear();

  // Polled: nothing until asked, then the newest reading.
  (*mock)->setPressure(14.6963);
  (*mock)->setPressure(20.5);
  command("P3");
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return values.size() == 1; }));
  EXPECT_NEAR(values[0], 20.5, 1e-9);

  // Continuous: every reading is sent; faults on some of them.
  command("P4");
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return (*mock)->continuous(); }));
  const std::map<int, Fault> faults = {
      {2, Fault::kGarbage}, {4, Fault::kBadChecksum}, {6, Fault::kDropout}, {8, Fault::kTruncate}};
  for (int i = 1; i <= 11; ++i) {
    if (auto f = faults.find(i); f != faults.end()) (*mock)->faults().inject(f->second);
    (*mock)->setPressure(30.0 + i);
  }
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return !values.empty() && values.back() == 41.0; }));
  std::set<double> delivered(values.begin() + 1, values.end());
  for (double v : delivered) EXPECT_TRUE(v == std::round(v) && v >= 31 && v <= 41) << v;  // only real readings
  for (int i : {1, 2, 3, 5, 7, 10, 11}) EXPECT_EQ(delivered.count(30.0 + i), 1u) << i;
  for (int i : {4, 6, 8}) EXPECT_EQ(delivered.count(30.0 + i), 0u) << i;
  EXPECT_GE(decoder.stats().malformed, 1u);

  // After an unplug and replug the sensor answers polls again through the reconnected port.
  ASSERT_TRUE((*mock)->pty().unplug().ok());
  ASSERT_TRUE((*mock)->pty().replug().ok());
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return rig.connected() && rig.transport->health().connects == 2; }));
  decoder.reset();
  command("P3");
  ASSERT_TRUE(pumpUntil(rig.ioc, [&] { return values.back() == 41.0 && values.size() >= delivered.size() + 2; }));
  EXPECT_GE((*mock)->commandsReceived(), 3u);
}

}  // namespace
}  // namespace vog::mock
