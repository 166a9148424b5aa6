#pragma once
// A mock ARIS sonar speaking the ARIS live protocol (PROTOCOLS.md "ARIS live protocol") on loopback
// sockets, so a client (vogd's ARIS driver, the tests) talks to it exactly as to a device:
//   - discovery: the aris.Availability beacon, once per beacon_period_s, to 127.0.0.1:beacon_port
//     (BUSY while a client is connected);
//   - commands: a TCP listener on 127.0.0.1:command_port, one controlling client at a time; the
//     bytes go through ArisCommandDecoder and each command through validateArisCommand() for the
//     configured model. A refused command is ignored (previous settings kept, so the client keeps
//     seeing the old cookie) and counted by reason; a refusal that breaks the stream
//     (arisCommandRefusalClosesStream) closes the connection. A client that sends nothing, PING
//     included, for keepalive_timeout_s is disconnected. Closing the connection stops the stream
//     (the receiver is cleared) and keeps the acoustic settings;
//   - frames: ping() turns the simulator's beam-order intensity frame into the frame the applied
//     acoustic settings describe, and ArisFrameSender sends it (sonar order, FramePart datagrams)
//     to the receiver from the socket bound to ack_port, where the receiver's FramePartAcks come
//     back; resends happen on the device thread at the sender's deadlines.
//     The sonar pings when ping() is called: the settings' frame_rate_hz is checked, not used, and
//     the interpacket delay of SET_FRAMESTREAM_SETTINGS is kept but not applied (loopback needs none);
//   - faults: seeded per-datagram loss (both directions: frame parts and acks), duplication and
//     reordering, and reboot(): everything the client set is forgotten, frame indices restart at 1,
//     and the sonar is silent (no beacon, no command listener) for a while.
//
// Every socket is bound to 127.0.0.1; frames go to the receiver the client names, which on loopback
// is a 127.x address (a socket bound to 127.0.0.1 cannot reach another network: such sends fail and
// are counted in send_errors).

#include "vog/core/result.hpp"
#include "vog/mock/aris_frame_sender.hpp"
#include "vog/mock/device_thread.hpp"
#include "vog/sonar/aris_command.hpp"
#include "vog/sonar/sonar_frame.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

namespace vog::mock {

struct ArisSonarMockConfig {
  std::uint32_t serial_number = 1234;
  sonar::ArisSystemType model = sonar::ArisSystemType::k1800;
  // Software version the beacon reports (ARIScope 2.8 era firmware; any value works for a client).
  std::uint32_t version_major = 2;
  std::uint32_t version_minor = 8;
  std::uint32_t version_build = 0;
  // Availability beacon destination on 127.0.0.1; 0 = no beacon. A real ARIS broadcasts to 56124
  // (sonar::kArisAvailabilityPort) once a second.
  std::uint16_t beacon_port = 0;
  double beacon_period_s = 1.0;  // in [0.01, 60]
  // TCP command port on 127.0.0.1 (a real ARIS: 56888); 0 = any free port (commandPort()).
  std::uint16_t command_port = 0;
  // UDP port on 127.0.0.1 the frames are sent from and the acks come to (FramePart.ack_port);
  // 0 = any free port (ackPort()).
  std::uint16_t ack_port = 0;
  // A controlling client silent this long is disconnected. The ARIS Integration SDK's clients send
  // PING every second; 3 s tolerates two lost keep-alives.
  double keepalive_timeout_s = 3.0;  // in [0.05, 3600]
  // How frames are cut and resent; mode is replaced by SET_FRAMESTREAM_SETTINGS and ack_port by the
  // bound ack port.
  ArisFrameSenderConfig sender;
  // The speed of sound the sonar uses to turn the acoustic settings' times into ranges (written to
  // the header's SoundSpeed). 1480 m/s: fresh water near 20 C.
  double sound_speed_mps = 1480.0;  // in [1400, 1600]
  // Intensity of output samples outside the simulator's window (no echo data there).
  std::uint8_t background = 0;
  std::uint64_t seed = 1;  // fault draws

  // Error naming the key and its value.
  Status validate() const;
};

// Per-datagram link faults; each probability in [0, 1].
struct ArisLinkFaults {
  double loss = 0.0;       // a frame part, or a received ack, is dropped
  double duplicate = 0.0;  // a frame part is sent twice
  double reorder = 0.0;    // a frame part is held and sent after the next one
  bool operator==(const ArisLinkFaults&) const = default;
};

// Why a ping produced no frame.
enum class ArisPingSkip : std::uint8_t {
  kRebooting,     // the sonar is down (reboot())
  kNoReceiver,    // no SET_FRAMESTREAM_RECEIVER since connecting, or 0.0.0.0
  kNoSettings,    // no SET_ACOUSTICS applied since start or the last reboot
  kTransmitOff,   // the applied settings have enable_transmit false
  kFrameInvalid,  // the input frame is empty or inconsistent (n_beams x n_samples != samples)
  kSendFailed,    // the sender refused the frame (header not encodable)
};
inline constexpr std::size_t kArisPingSkipCount = 6;
std::string_view arisPingSkipName(ArisPingSkip reason);

struct ArisSonarMockStats {
  std::uint64_t connections = 0;                // clients that took control
  std::uint64_t connections_refused_busy = 0;   // accepted and closed: another client was in control
  std::uint64_t disconnects_keepalive = 0;      // silent for keepalive_timeout_s
  std::uint64_t disconnects_stream_broken = 0;  // a refusal that closes the stream
  std::uint64_t commands_applied = 0;
  std::array<std::uint64_t, sonar::kArisCommandRefusalCount> commands_refused{};
  std::uint64_t pings = 0;  // ping() calls
  std::array<std::uint64_t, kArisPingSkipCount> pings_skipped{};
  std::uint64_t frames_sent = 0;      // frames handed to the sender
  std::uint64_t frames_finished = 0;  // acked complete (PESSIMISTIC_RETRY)
  std::uint64_t frames_given_up = 0;
  std::uint64_t datagrams_sent = 0;  // on the wire, duplicates included
  std::uint64_t datagrams_resent = 0;
  std::uint64_t datagrams_lost = 0;  // dropped by the loss fault
  std::uint64_t datagrams_duplicated = 0;
  std::uint64_t datagrams_reordered = 0;
  std::uint64_t acks_received = 0;  // ack datagrams read, lost ones included
  std::uint64_t acks_lost = 0;      // dropped by the loss fault
  std::uint64_t beacons_sent = 0;
  std::uint64_t reboots = 0;
  std::uint64_t send_errors = 0;  // sendto() failures (receiver unreachable from loopback, ...)

  std::uint64_t refusedBy(sonar::ArisCommandRefusal r) const { return commands_refused[static_cast<std::size_t>(r)]; }
  std::uint64_t refusedTotal() const;
  std::uint64_t skippedBy(ArisPingSkip r) const { return pings_skipped[static_cast<std::size_t>(r)]; }
};

// The frame the acoustic settings describe, made from the simulator's frame `in` (beam order, any
// beam count and window): `beams` beams taken by nearest centre (both fans span the same field of
// view, beam 0 at -fov/2); settings.samples_per_beam samples from SampleStartDelay c / 2, each
// SamplePeriod c / 2 long, each the maximum of the input samples overlapping its range interval (so
// an echo's leading edge lands in the output sample that holds its range); output samples outside
// the input window get `background`. frame_index and stamp_ns are left 0.
sonar::SonarFrame arisSettingsFrame(const sonar::SonarFrame& in, int beams, const sonar::ArisAcousticSettings& settings,
                                    double sound_speed_mps, std::uint8_t background);

// What the client has set and the sonar keeps.
struct ArisMockSettings {
  bool connected = false;  // a client is in control
  bool rebooting = false;
  std::optional<sonar::ArisSetFrameStreamReceiver> receiver;  // none: no stream
  sonar::ArisSetFrameStreamSettings stream;
  std::optional<sonar::ArisAcousticSettings> acoustics;  // with their cookie; none until SET_ACOUSTICS
  sonar::ArisSalinity salinity = sonar::ArisSalinity::kFresh;
  std::optional<float> focus_range_m;
  std::string date_time;  // the last SET_DATETIME, empty if none
};

// Lifecycle: create() binds the sockets and starts the device thread (beacon right away); ping() per
// simulated ping; reboot() on command; destruction closes everything. Invariants: at most one
// controlling client; frame indices count up from 1 with each frame sent and restart at 1 after a
// reboot; a frame is only made with applied (validated) settings, and carries their cookie.
// Threading: public members from any thread; every descriptor and every piece of state below is
// touched only by the device thread (public members run their work there through DeviceThread::call).
class ArisSonarMock {
 public:
  static Result<std::unique_ptr<ArisSonarMock>> create(ArisSonarMockConfig config);
  ~ArisSonarMock();
  ArisSonarMock(const ArisSonarMock&) = delete;
  ArisSonarMock& operator=(const ArisSonarMock&) = delete;

  // One ping of the simulator: `frame` in beam order (samples[s * n_beams + b]) over its window.
  // Sends the frame the applied settings describe, or counts why not (stats().pings_skipped); an
  // error only when the frame is invalid or the sender refused it (also counted).
  Status ping(const sonar::SonarFrame& frame, std::int64_t stamp_ns);

  // Faults on the datagrams from now on; error naming the value if a probability is outside [0, 1].
  Status setFaults(const ArisLinkFaults& faults);
  ArisLinkFaults faults() const;
  // Drops the client and forgets every setting; silent for down_s seconds (in [0, 3600]), then
  // listens and beacons again on the same ports.
  Status reboot(double down_s);

  std::uint16_t commandPort() const { return command_port_; }
  std::uint16_t ackPort() const { return ack_port_; }
  ArisSonarMockStats stats() const;
  ArisMockSettings appliedSettings() const;

 private:
  explicit ArisSonarMock(ArisSonarMockConfig config);
  Status open();
  Status listen();
  void collect(std::vector<pollfd>& fds);
  void onReady(const std::vector<pollfd>& fds);
  void onTimers(double now_s);
  void acceptClient(double now_s);
  void readClient(double now_s);
  void applyCommand(const sonar::ArisCommand& command);
  void disconnect();
  void readAcks(double now_s);
  void sendBeacon();
  void resetSender();
  std::optional<double> nextDeadline() const;
  // The datagram through the link faults, to the receiver.
  void transmit(std::vector<std::uint8_t> datagram, double now_s);
  void sendToReceiver(const std::vector<std::uint8_t>& datagram);
  bool draw(double probability);
  Status pingOnThread(const sonar::SonarFrame& frame, std::int64_t stamp_ns);

  const ArisSonarMockConfig config_;
  std::uint16_t command_port_ = 0;  // set by create(), constant after
  std::uint16_t ack_port_ = 0;      // set by create(), constant after

  // Device thread only, from here on.
  int listen_fd_ = -1;                                // -1 while rebooting
  int client_fd_ = -1;                                // the controlling client, -1 if none
  int data_fd_ = -1;                                  // UDP on ack_port_: frame parts out, acks in
  int beacon_fd_ = -1;                                // UDP, beacons out
  int timer_fd_ = -1;                                 // timerfd armed at nextDeadline() before each poll
  std::optional<sonar::ArisCommandDecoder> decoder_;  // one per connection
  double last_command_s_ = 0.0;                       // the client's last message (keep-alive)
  double next_beacon_s_ = 0.0;
  std::optional<double> down_until_s_;  // set while rebooting
  ArisMockSettings settings_;
  std::uint32_t next_frame_index_ = 1;
  std::unique_ptr<ArisFrameSender> sender_;    // replaced when the stream mode changes or the stream stops
  ArisFrameSenderStats retired_sender_stats_;  // summed stats of the senders replaced
  ArisLinkFaults faults_;
  std::mt19937_64 rng_;
  std::optional<std::vector<std::uint8_t>> held_;  // a reordered datagram waiting for the next one
  double held_since_s_ = 0.0;
  ArisSonarMockStats stats_;

  // Last: stopped (joined) in the destructor before the members it uses go. Mutable: the const
  // accessors run their reads on it too.
  mutable DeviceThread thread_;
};

}  // namespace vog::mock
