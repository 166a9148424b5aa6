// The mock ARIS sonar over real loopback sockets, driven by a small client made of the protocol's
// own pieces (encodeArisCommand, ArisFrameAssembler, encodeArisFramePartAck, decodeArisAvailability).
// Every port is ephemeral; every wait is bounded.

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include "vog/mock/aris_sonar_mock.hpp"
#include "vog/sonar/aris_availability.hpp"
#include "vog/sonar/aris_command.hpp"
#include "vog/sonar/aris_frame_assembler.hpp"

namespace vog::mock {
namespace {

using sonar::ArisCommandRefusal;
using sonar::SonarFrame;
using Clock = std::chrono::steady_clock;

// The simulator's frame: 96 beams x 512 samples over 0.5-12.5 m, background 10, one bright sample.
constexpr int kInBeams = 96;
constexpr int kInSamples = 512;
constexpr double kInStart_m = 0.5;
constexpr double kInLength_m = 12.0;
constexpr int kBrightBeam = 40;
constexpr double kBrightRange_m = 5.0;
constexpr std::uint8_t kBackground = 10;

// Generous bound for anything that should happen within milliseconds on loopback.
constexpr double kWait_s = 2.0;

double seconds() { return std::chrono::duration<double>(Clock::now().time_since_epoch()).count(); }

SonarFrame simulatorFrame(int bright_beam = kBrightBeam) {
  SonarFrame f;
  f.n_beams = kInBeams;
  f.n_samples = kInSamples;
  f.window_start_m = kInStart_m;
  f.window_length_m = kInLength_m;
  f.samples.assign(static_cast<std::size_t>(kInBeams * kInSamples), kBackground);
  const int s = static_cast<int>((kBrightRange_m - kInStart_m) / f.sampleLength_m());
  f.samples[static_cast<std::size_t>(s * kInBeams + bright_beam)] = 255;
  return f;
}

// Waits until pred() holds, up to timeout_s.
bool waitFor(const std::function<bool()>& pred, double timeout_s = kWait_s) {
  const double end = seconds() + timeout_s;
  while (seconds() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return pred();
}

bool readable(int fd, double timeout_s) {
  pollfd p{fd, POLLIN, 0};
  return ::poll(&p, 1, static_cast<int>(timeout_s * 1000)) > 0;
}

sockaddr_in loopback(std::uint16_t port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return a;
}

// A UDP socket bound to 127.0.0.1 on an ephemeral port.
struct Udp {
  int fd = -1;
  std::uint16_t port = 0;
  Udp() {
    fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    sockaddr_in a = loopback(0);
    EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    socklen_t len = sizeof(a);
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~Udp() { ::close(fd); }
  Udp(const Udp&) = delete;
  Udp& operator=(const Udp&) = delete;
  std::optional<std::vector<std::uint8_t>> receive(double timeout_s) {
    std::vector<std::uint8_t> buf(65536);
    if (!readable(fd, timeout_s)) return std::nullopt;
    const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
    if (n < 0) return std::nullopt;
    buf.resize(static_cast<std::size_t>(n));
    return buf;
  }
  void drain() {
    while (receive(0.0)) {
    }
  }
};

// The sonar's client: the command connection, and the frame receiver that acks every part.
class Client {
 public:
  bool connect(std::uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const sockaddr_in a = loopback(port);
    if (::connect(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof(a)) != 0) {
      ::close(fd_);
      fd_ = -1;
      return false;
    }
    return true;
  }
  ~Client() {
    if (fd_ >= 0) ::close(fd_);
  }
  void close() {
    ::close(fd_);
    fd_ = -1;
  }
  void sendBytes(const std::vector<std::uint8_t>& bytes) {
    ASSERT_EQ(::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL), static_cast<ssize_t>(bytes.size()));
  }
  void send(const sonar::ArisCommand& command) { sendBytes(sonar::encodeArisCommand(command)); }
  // True once the sonar has closed the connection (read returns 0 or an error).
  bool closedByPeer(double timeout_s = kWait_s) {
    const double end = seconds() + timeout_s;
    std::uint8_t b = 0;
    while (seconds() < end) {
      if (!readable(fd_, end - seconds())) continue;
      if (::recv(fd_, &b, 1, 0) <= 0) return true;
    }
    return false;
  }
  // The commands a client sends right after connecting: receiver, stream settings, acoustics.
  void setUp(const sonar::ArisAcousticSettings& acoustics,
             sonar::ArisPacketLossMitigation mode = sonar::ArisPacketLossMitigation::kPessimisticRetry) {
    send(sonar::ArisSetDateTime{sonar::arisDateTimeText(1'700'000'000)});
    send(sonar::ArisSetFrameStreamReceiver{"127.0.0.1", frames_.port});
    send(sonar::ArisSetFrameStreamSettings{mode, false, 0});
    send(acoustics);
  }
  // The next frame the datagrams complete, acking every part; none after timeout_s.
  std::optional<sonar::ArisLiveFrame> receiveFrame(double timeout_s = kWait_s) {
    const double end = seconds() + timeout_s;
    while (seconds() < end) {
      auto d = frames_.receive(end - seconds());
      if (!d) continue;
      sonar::ArisPartResult r = assembler_.add(*d, seconds());
      if (r.ack) {
        const auto ack = sonar::encodeArisFramePartAck(*r.ack);
        const sockaddr_in to = loopback(static_cast<std::uint16_t>(r.ack_port));
        ::sendto(frames_.fd, ack.data(), ack.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof(to));
      }
      if (r.frame) return std::move(r.frame);
    }
    return std::nullopt;
  }
  // Answers the sonar's datagrams (resends of a frame already complete get their ack again) until
  // pred() holds, up to timeout_s.
  bool serveUntil(const std::function<bool()>& pred, double timeout_s = kWait_s) {
    const double end = seconds() + timeout_s;
    while (!pred() && seconds() < end) {
      if (receiveFrame(0.005)) ADD_FAILURE() << "unexpected frame";
    }
    return pred();
  }
  const sonar::ArisFrameAssemblerStats& assemblerStats() const { return assembler_.stats(); }

 private:
  int fd_ = -1;
  Udp frames_;
  sonar::ArisFrameAssembler assembler_;
};

// The settings of an ARIS 1800 in 96-beam mode looking 1-10 m with 1000 samples, stamped.
sonar::ArisAcousticSettings settings(sonar::ArisSettingsCookies& cookies, double window_end_m = 10.0,
                                     std::uint32_t ping_mode = 3) {
  sonar::ArisSonarConfig config;
  config.window_start_m = 1.0;
  config.window_end_m = window_end_m;
  config.ping_mode = ping_mode;
  auto derived = sonar::deriveArisAcousticSettings(config);
  EXPECT_TRUE(derived.ok()) << derived.error().message;
  sonar::ArisAcousticSettings s = derived->acoustic;
  cookies.stamp(s);
  return s;
}

ArisSonarMockConfig mockConfig() {
  ArisSonarMockConfig c;
  c.background = 0;
  c.sender.part_bytes = 8192;
  return c;
}

std::unique_ptr<ArisSonarMock> makeMock(const ArisSonarMockConfig& config) {
  auto mock = ArisSonarMock::create(config);
  EXPECT_TRUE(mock.ok()) << mock.error().message;
  return mock.ok() ? std::move(mock).value() : nullptr;
}

// The beam and the sample of the brightest output sample.
std::pair<int, int> brightest(const SonarFrame& f) {
  int best_b = -1, best_s = -1, best = -1;
  for (int s = 0; s < f.n_samples; ++s) {
    for (int b = 0; b < f.n_beams; ++b) {
      if (f.at(b, s) > best) {
        best = f.at(b, s);
        best_b = b;
        best_s = s;
      }
    }
  }
  return {best_b, best_s};
}

TEST(ArisSonarMock, ConfigErrorsNameTheKey) {
  ArisSonarMockConfig c;
  c.keepalive_timeout_s = 0.0;
  auto mock = ArisSonarMock::create(c);
  ASSERT_FALSE(mock.ok());
  EXPECT_NE(mock.error().message.find("keepalive_timeout_s"), std::string::npos) << mock.error().message;
  c = ArisSonarMockConfig{};
  c.sender.part_bytes = 0;
  mock = ArisSonarMock::create(c);
  ASSERT_FALSE(mock.ok());
  EXPECT_NE(mock.error().message.find("sender.part_bytes"), std::string::npos) << mock.error().message;
}

TEST(ArisSonarMock, BeaconAnnouncesTheSonarAndSaysBusyWhileControlled) {
  Udp beacons;
  ArisSonarMockConfig c = mockConfig();
  c.serial_number = 4321;
  c.model = sonar::ArisSystemType::k3000;
  c.beacon_port = beacons.port;
  c.beacon_period_s = 0.02;
  auto mock = makeMock(c);
  ASSERT_TRUE(mock);
  const auto nextBeacon = [&]() -> std::optional<sonar::ArisAvailability> {
    auto d = beacons.receive(kWait_s);
    if (!d) return std::nullopt;
    auto a = sonar::decodeArisAvailability(*d);
    EXPECT_TRUE(a.ok()) << a.error().message;
    return a.ok() ? std::optional(*a) : std::nullopt;
  };
  auto first = nextBeacon();
  ASSERT_TRUE(first);
  EXPECT_EQ(first->serial_number, 4321u);
  EXPECT_EQ(first->system_type, sonar::ArisSystemType::k3000);
  EXPECT_EQ(first->version_major, c.version_major);
  EXPECT_FALSE(first->busy);

  Client client;
  ASSERT_TRUE(client.connect(mock->commandPort()));
  ASSERT_TRUE(waitFor([&] { return mock->appliedSettings().connected; }));
  beacons.drain();
  auto busy = nextBeacon();
  ASSERT_TRUE(busy);
  EXPECT_TRUE(busy->busy);

  client.close();
  ASSERT_TRUE(waitFor([&] { return !mock->appliedSettings().connected; }));
  beacons.drain();
  auto free_again = nextBeacon();
  ASSERT_TRUE(free_again);
  EXPECT_FALSE(free_again->busy);
  EXPECT_GE(mock->stats().beacons_sent, 3u);
}

TEST(ArisSonarMock, SecondClientIsClosedWhileOneControls) {
  auto mock = makeMock(mockConfig());
  ASSERT_TRUE(mock);
  Client first, second;
  ASSERT_TRUE(first.connect(mock->commandPort()));
  ASSERT_TRUE(waitFor([&] { return mock->stats().connections == 1; }));
  ASSERT_TRUE(second.connect(mock->commandPort()));
  EXPECT_TRUE(second.closedByPeer());
  EXPECT_EQ(mock->stats().connections_refused_busy, 1u);
  EXPECT_TRUE(mock->appliedSettings().connected);
}

TEST(ArisSonarMock, FrameHasTheSettingsCookieGeometryAndEcho) {
  auto mock = makeMock(mockConfig());
  ASSERT_TRUE(mock);
  sonar::ArisSettingsCookies cookies;
  const sonar::ArisAcousticSettings acoustics = settings(cookies);

  // Before any client: no receiver, no frame.
  ASSERT_TRUE(mock->ping(simulatorFrame(), 1'000).ok());
  EXPECT_EQ(mock->stats().skippedBy(ArisPingSkip::kNoReceiver), 1u);

  Client client;
  ASSERT_TRUE(client.connect(mock->commandPort()));
  client.setUp(acoustics);
  client.send(sonar::ArisSetSalinity{sonar::ArisSalinity::kBrackish});
  ASSERT_TRUE(waitFor([&] { return mock->stats().commands_applied == 5; }));
  EXPECT_EQ(mock->appliedSettings().acoustics, acoustics);

  const std::int64_t stamp_ns = 1'700'000'000'123'456'000LL;
  ASSERT_TRUE(mock->ping(simulatorFrame(), stamp_ns).ok());
  auto got = client.receiveFrame();
  ASSERT_TRUE(got);
  const sonar::ArisFrameMeta& meta = got->meta;
  EXPECT_EQ(meta.frame_index, 1u);
  EXPECT_EQ(meta.settings_cookie, acoustics.cookie);
  EXPECT_EQ(meta.ping_mode, acoustics.ping_mode);
  EXPECT_EQ(meta.samples_per_beam, acoustics.samples_per_beam);
  EXPECT_EQ(meta.sample_start_delay_us, acoustics.sample_start_delay_us);
  EXPECT_EQ(meta.sample_period_us, acoustics.sample_period_us);
  EXPECT_FLOAT_EQ(meta.sound_speed_mps, 1480.0f);
  EXPECT_EQ(meta.salinity, 15u);
  EXPECT_FALSE(meta.reordered_samples);
  EXPECT_EQ(meta.frame_time_us, static_cast<std::uint64_t>(stamp_ns / 1000));

  const SonarFrame& f = got->frame;
  EXPECT_EQ(f.n_beams, 96);
  EXPECT_EQ(f.n_samples, static_cast<int>(acoustics.samples_per_beam));
  const double sample_m = acoustics.sample_period_us * 1e-6 * 1480.0 / 2.0;
  EXPECT_NEAR(f.window_start_m, acoustics.sample_start_delay_us * 1e-6 * 740.0, 1e-6);
  EXPECT_NEAR(f.sampleLength_m(), sample_m, 1e-6);
  const auto [beam, sample] = brightest(f);
  EXPECT_EQ(beam, kBrightBeam);
  EXPECT_EQ(f.at(beam, sample), 255);
  // The input's bright sample spans [r0, r0 + input sample length]: an output sample overlapping it
  // holds it, and its centre is within one output sample of the echo.
  const SonarFrame in = simulatorFrame();
  const double r0 =
      in.window_start_m + std::floor((kBrightRange_m - kInStart_m) / in.sampleLength_m()) * in.sampleLength_m();
  EXPECT_LE(std::abs(f.rangeOfSample_m(sample) - (r0 + in.sampleLength_m() / 2)), sample_m + in.sampleLength_m() / 2);
  // Background everywhere the input has it; nothing beyond the input's window end (12.5 m) here.
  EXPECT_EQ(f.at(0, 0), kBackground);

  // A second ping: the next frame index.
  ASSERT_TRUE(mock->ping(simulatorFrame(), stamp_ns + 200'000'000).ok());
  got = client.receiveFrame();
  ASSERT_TRUE(got);
  EXPECT_EQ(got->meta.frame_index, 2u);
  const ArisSonarMockStats st = mock->stats();
  EXPECT_EQ(st.frames_sent, 2u);
  EXPECT_TRUE(waitFor([&] { return mock->stats().frames_finished == 2; }));
}

TEST(ArisSonarMock, BeamsAndSamplesOutsideTheInputFollowTheSettings) {
  ArisSonarMockConfig c = mockConfig();
  c.background = 3;
  auto mock = makeMock(c);
  ASSERT_TRUE(mock);
  sonar::ArisSettingsCookies cookies;
  // Ping mode 1: 48 beams; a window to 14 m, past the input's 12.5 m end.
  const sonar::ArisAcousticSettings acoustics = settings(cookies, 14.0, 1);
  Client client;
  ASSERT_TRUE(client.connect(mock->commandPort()));
  client.setUp(acoustics);
  ASSERT_TRUE(waitFor([&] { return mock->stats().commands_applied == 4; }));
  ASSERT_TRUE(mock->ping(simulatorFrame(kBrightBeam + 1), 0).ok());
  auto got = client.receiveFrame();
  ASSERT_TRUE(got);
  const SonarFrame& f = got->frame;
  EXPECT_EQ(f.n_beams, 48);
  EXPECT_EQ(brightest(f).first, kBrightBeam / 2);  // the nearest input beam of output beam b is 2b + 1
  EXPECT_EQ(f.at(0, f.n_samples - 1), 3);          // beyond the input window: the mock's background
  EXPECT_EQ(f.at(0, 0), kBackground);
}

TEST(ArisSonarMock, RefusedCommandKeepsTheOldCookie) {
  auto mock = makeMock(mockConfig());
  ASSERT_TRUE(mock);
  sonar::ArisSettingsCookies cookies;
  const sonar::ArisAcousticSettings good = settings(cookies);
  Client client;
  ASSERT_TRUE(client.connect(mock->commandPort()));
  client.setUp(good);
  ASSERT_TRUE(waitFor([&] { return mock->stats().commands_applied == 4; }));

  sonar::ArisAcousticSettings bad = good;
  bad.frame_rate_hz = 99.0f;
  cookies.stamp(bad);
  ASSERT_NE(bad.cookie, good.cookie);
  client.send(bad);
  ASSERT_TRUE(waitFor([&] { return mock->stats().refusedBy(ArisCommandRefusal::kFrameRateOutOfRange) == 1; }));
  EXPECT_EQ(mock->stats().commands_applied, 4u);
  EXPECT_EQ(mock->appliedSettings().acoustics, good);

  ASSERT_TRUE(mock->ping(simulatorFrame(), 0).ok());
  auto got = client.receiveFrame();
  ASSERT_TRUE(got);
  EXPECT_EQ(got->meta.settings_cookie, good.cookie);
  EXPECT_EQ(mock->stats().refusedTotal(), 1u);
}

TEST(ArisSonarMock, MalformedLengthPrefixClosesTheConnection) {
  auto mock = makeMock(mockConfig());
  ASSERT_TRUE(mock);
  Client client;
  ASSERT_TRUE(client.connect(mock->commandPort()));
  client.send(sonar::ArisPing{});
  client.sendBytes({0x7F, 0xFF, 0xFF, 0xFF, 0x08, 0x0E});  // a 2 GiB message
  EXPECT_TRUE(client.closedByPeer());
  const ArisSonarMockStats st = mock->stats();
  EXPECT_EQ(st.refusedBy(ArisCommandRefusal::kLengthOutOfBounds), 1u);
  EXPECT_EQ(st.disconnects_stream_broken, 1u);
  EXPECT_EQ(st.commands_applied, 1u);
  // The sonar takes a new client afterwards.
  Client again;
  ASSERT_TRUE(again.connect(mock->commandPort()));
  EXPECT_TRUE(waitFor([&] { return mock->stats().connections == 2; }));
}

TEST(ArisSonarMock, SilentClientIsDisconnectedAfterTheKeepAliveTimeout) {
  ArisSonarMockConfig c = mockConfig();
  c.keepalive_timeout_s = 0.2;
  auto mock = makeMock(c);
  ASSERT_TRUE(mock);
  sonar::ArisSettingsCookies cookies;
  const sonar::ArisAcousticSettings acoustics = settings(cookies);
  Client client;
  ASSERT_TRUE(client.connect(mock->commandPort()));
  client.setUp(acoustics);
  // PINGs every 50 ms keep the connection past several timeouts.
  const double until = seconds() + 0.6;
  while (seconds() < until) {
    client.send(sonar::ArisPing{});
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(mock->appliedSettings().connected);
  EXPECT_EQ(mock->stats().disconnects_keepalive, 0u);
  // Then silence.
  const double silent_from = seconds();
  EXPECT_TRUE(client.closedByPeer());
  // The last PING went out up to 50 ms before the silence was measured from.
  EXPECT_GE(seconds() - silent_from, 0.2 - 0.05 - 0.01);
  EXPECT_EQ(mock->stats().disconnects_keepalive, 1u);
  // The stream stopped, the acoustic settings stay.
  const ArisMockSettings s = mock->appliedSettings();
  EXPECT_FALSE(s.receiver);
  EXPECT_EQ(s.acoustics, acoustics);
  ASSERT_TRUE(mock->ping(simulatorFrame(), 0).ok());
  EXPECT_EQ(mock->stats().skippedBy(ArisPingSkip::kNoReceiver), 1u);
}

TEST(ArisSonarMock, LossyLinkWithPessimisticRetryStillCompletesFrames) {
  ArisSonarMockConfig c = mockConfig();
  c.seed = 7;
  c.sender.part_bytes = 4096;  // 24 parts per frame of 96 x ~1000 samples
  c.sender.max_retries = 16;   // the test waits for each frame, so a frame may take many rounds
  auto mock = makeMock(c);
  ASSERT_TRUE(mock);
  ASSERT_TRUE(mock->setFaults({.loss = 0.05, .duplicate = 0.05, .reorder = 0.05}).ok());
  EXPECT_FALSE(mock->setFaults({.loss = 1.5}).ok());
  sonar::ArisSettingsCookies cookies;
  Client client;
  ASSERT_TRUE(client.connect(mock->commandPort()));
  client.setUp(settings(cookies));
  ASSERT_TRUE(waitFor([&] { return mock->stats().commands_applied == 4; }));

  constexpr int kFrames = 20;
  std::set<std::uint32_t> indices;
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_TRUE(mock->ping(simulatorFrame(), i * 100'000'000LL).ok());
    auto got = client.receiveFrame();
    ASSERT_TRUE(got) << "frame " << i + 1;
    indices.insert(got->meta.frame_index);
    EXPECT_EQ(brightest(got->frame).first, kBrightBeam);
    EXPECT_EQ(got->frame.at(brightest(got->frame).first, brightest(got->frame).second), 255);
    // A lost final ack makes the sonar resend: answered until the sonar knows the frame is complete.
    ASSERT_TRUE(client.serveUntil([&] { return mock->stats().frames_finished == static_cast<std::uint64_t>(i + 1); }));
  }
  EXPECT_EQ(indices.size(), static_cast<std::size_t>(kFrames));
  EXPECT_EQ(*indices.begin(), 1u);
  EXPECT_EQ(*indices.rbegin(), static_cast<std::uint32_t>(kFrames));
  const ArisSonarMockStats st = mock->stats();
  EXPECT_GT(st.datagrams_lost, 0u);
  EXPECT_GT(st.datagrams_duplicated, 0u);
  EXPECT_GT(st.datagrams_reordered, 0u);
  EXPECT_GT(st.datagrams_resent, 0u);
  EXPECT_GT(client.assemblerStats().datagrams_duplicated, 0u);
  EXPECT_EQ(st.frames_given_up, 0u);
  EXPECT_EQ(st.frames_finished, static_cast<std::uint64_t>(kFrames));
}

TEST(ArisSonarMock, RebootForgetsSettingsAndRestartsFrameIndices) {
  Udp beacons;
  ArisSonarMockConfig c = mockConfig();
  c.beacon_port = beacons.port;
  c.beacon_period_s = 0.02;
  auto mock = makeMock(c);
  ASSERT_TRUE(mock);
  const std::uint16_t port = mock->commandPort();
  sonar::ArisSettingsCookies cookies;
  const sonar::ArisAcousticSettings acoustics = settings(cookies);
  Client client;
  ASSERT_TRUE(client.connect(port));
  client.setUp(acoustics);
  ASSERT_TRUE(waitFor([&] { return mock->stats().commands_applied == 4; }));
  for (std::uint32_t i = 1; i <= 2; ++i) {
    ASSERT_TRUE(mock->ping(simulatorFrame(), 0).ok());
    auto got = client.receiveFrame();
    ASSERT_TRUE(got);
    EXPECT_EQ(got->meta.frame_index, i);
  }

  constexpr double kDown_s = 0.3;
  ASSERT_TRUE(mock->reboot(kDown_s).ok());
  const double rebooted_at = seconds();
  EXPECT_TRUE(client.closedByPeer());
  ArisMockSettings s = mock->appliedSettings();
  EXPECT_TRUE(s.rebooting);
  EXPECT_FALSE(s.connected);
  EXPECT_FALSE(s.receiver);
  EXPECT_FALSE(s.acoustics);
  EXPECT_TRUE(s.date_time.empty());
  // Silent while down: no listener, no beacon, no frame.
  beacons.drain();
  Client early;
  EXPECT_FALSE(early.connect(port));
  ASSERT_TRUE(mock->ping(simulatorFrame(), 0).ok());
  EXPECT_EQ(mock->stats().skippedBy(ArisPingSkip::kRebooting), 1u);
  if (seconds() - rebooted_at < kDown_s - 0.1) {
    EXPECT_FALSE(beacons.receive(0.05));
  }

  // Back on the same port; the beacon resumes.
  Client after;
  ASSERT_TRUE(waitFor([&] { return after.connect(port); }));
  EXPECT_GE(seconds() - rebooted_at, kDown_s - 0.01);
  EXPECT_TRUE(beacons.receive(kWait_s));
  EXPECT_EQ(mock->commandPort(), port);
  after.setUp(acoustics);
  ASSERT_TRUE(waitFor([&] { return mock->stats().commands_applied == 8; }));
  ASSERT_TRUE(mock->ping(simulatorFrame(), 0).ok());
  auto got = after.receiveFrame();
  ASSERT_TRUE(got);
  EXPECT_EQ(got->meta.frame_index, 1u);
  EXPECT_EQ(got->meta.settings_cookie, acoustics.cookie);
  EXPECT_EQ(mock->stats().reboots, 1u);
}

}  // namespace
}  // namespace vog::mock
