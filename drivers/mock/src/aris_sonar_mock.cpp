#include "vog/mock/aris_sonar_mock.hpp"

#include "vog/sonar/aris_availability.hpp"
#include "vog/sonar/sonar_files.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <numeric>
#include <type_traits>
#include <variant>

namespace vog::mock {
namespace {

constexpr std::array<std::string_view, kArisPingSkipCount> kPingSkipNames = {
    "rebooting", "no_receiver", "no_settings", "transmit_off", "frame_invalid", "send_failed"};

// A reordered datagram is held at most this long when no other datagram follows it (the last part
// of a frame): the reorder fault delays it past the next one, it does not lose it.
constexpr double kReorderHoldMaxS = 0.002;
// Bytes read from the command connection per read() call; a real command is under 100 bytes.
constexpr std::size_t kCommandReadBytes = 4096;
// An ack is two small varints; anything longer is not an ack, and is still read whole to drop it.
constexpr std::size_t kAckReadBytes = 2048;
// Connections waiting in the listener's queue (a second client is accepted and closed at once).
constexpr int kListenBacklog = 4;
// While rebooting, a listener that could not be bound again is retried this often.
constexpr double kRelistenRetryS = 0.1;

double monotonicNow_s() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

void closeFd(int& fd) {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

sockaddr_in loopbackAddress(std::uint16_t port) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  return addr;
}

Result<std::uint16_t> boundPort(int fd, const std::string& what) {
  sockaddr_in addr{};
  socklen_t len = sizeof(addr);
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) return Error{errnoText(what + " getsockname")};
  return ntohs(addr.sin_port);
}

bool inUnitInterval(double p) { return p >= 0.0 && p <= 1.0; }

void addSenderStats(ArisFrameSenderStats& sum, const ArisFrameSenderStats& s) {
  sum.frames_sent += s.frames_sent;
  sum.frames_finished += s.frames_finished;
  sum.frames_given_up += s.frames_given_up;
  sum.frames_given_up_for_next += s.frames_given_up_for_next;
  sum.datagrams_sent += s.datagrams_sent;
  sum.datagrams_resent += s.datagrams_resent;
  sum.retries += s.retries;
  sum.acks += s.acks;
  sum.acks_malformed += s.acks_malformed;
  sum.acks_stale += s.acks_stale;
}

}  // namespace

sonar::SonarFrame arisSettingsFrame(const sonar::SonarFrame& in, int beams, const sonar::ArisAcousticSettings& settings,
                                    double sound_speed_mps, std::uint8_t background) {
  const double half_c = sound_speed_mps / 2.0;
  sonar::SonarFrame out;
  out.n_beams = beams;
  out.n_samples = static_cast<int>(settings.samples_per_beam);
  out.sound_speed_mps = sound_speed_mps;
  // ARIS File SDK, "range of a sample": start = SampleStartDelay x c / 2, length = SamplePeriod x c / 2.
  out.window_start_m = settings.sample_start_delay_us * 1e-6 * half_c;
  const double sample_m = settings.sample_period_us * 1e-6 * half_c;
  out.window_length_m = sample_m * out.n_samples;
  out.samples.assign(static_cast<std::size_t>(out.n_beams) * static_cast<std::size_t>(out.n_samples), background);

  std::vector<int> beam_in(static_cast<std::size_t>(beams));
  for (int b = 0; b < beams; ++b) {
    beam_in[static_cast<std::size_t>(b)] =
        std::min(in.n_beams - 1, static_cast<int>((2LL * b + 1) * in.n_beams / (2LL * beams)));
  }
  const double in_sample_m = in.window_length_m / in.n_samples;
  // Tolerance on the sample boundaries, so a float rounding does not pull in a sample that only
  // touches the interval.
  constexpr double kEdge = 1e-9;
  for (int j = 0; j < out.n_samples; ++j) {
    const double a = out.window_start_m + j * sample_m;
    const double first = std::floor((a - in.window_start_m) / in_sample_m + kEdge);
    const double last = std::ceil((a + sample_m - in.window_start_m) / in_sample_m - kEdge) - 1.0;
    const int s0 = static_cast<int>(std::max(first, 0.0));
    const int s1 = static_cast<int>(std::min(last, static_cast<double>(in.n_samples - 1)));
    if (first > in.n_samples - 1 || last < 0.0 || s0 > s1) continue;
    for (int b = 0; b < beams; ++b) {
      std::uint8_t v = 0;
      for (int s = s0; s <= s1; ++s) v = std::max(v, in.at(beam_in[static_cast<std::size_t>(b)], s));
      out.samples[static_cast<std::size_t>(j) * static_cast<std::size_t>(beams) + static_cast<std::size_t>(b)] = v;
    }
  }
  return out;
}

std::string_view arisPingSkipName(ArisPingSkip reason) { return kPingSkipNames[static_cast<std::size_t>(reason)]; }

std::uint64_t ArisSonarMockStats::refusedTotal() const {
  return std::accumulate(commands_refused.begin(), commands_refused.end(), std::uint64_t{0});
}

Status ArisSonarMockConfig::validate() const {
  if (static_cast<std::size_t>(model) > static_cast<std::size_t>(sonar::ArisSystemType::k1200)) {
    return Error{"model: " + std::to_string(static_cast<int>(model)) + ", must be 0 (1800), 1 (3000) or 2 (1200)"};
  }
  if (!(beacon_period_s >= 0.01 && beacon_period_s <= 60.0)) {
    return Error{"beacon_period_s: " + std::to_string(beacon_period_s) + ", must be in [0.01, 60]"};
  }
  if (!(keepalive_timeout_s >= 0.05 && keepalive_timeout_s <= 3600.0)) {
    return Error{"keepalive_timeout_s: " + std::to_string(keepalive_timeout_s) + ", must be in [0.05, 3600]"};
  }
  if (!(sound_speed_mps >= 1400.0 && sound_speed_mps <= 1600.0)) {
    return Error{"sound_speed_mps: " + std::to_string(sound_speed_mps) + ", must be in [1400, 1600]"};
  }
  ArisFrameSenderConfig sender_checked = sender;
  sender_checked.ack_port = 1;  // replaced by the bound ack port
  if (Status s = sender_checked.validate(); !s.ok()) return Error{"sender." + s.error().message};
  return Status::success();
}

Result<std::unique_ptr<ArisSonarMock>> ArisSonarMock::create(ArisSonarMockConfig config) {
  if (Status s = config.validate(); !s.ok()) return Error{"ARIS sonar mock: " + s.error().message};
  std::unique_ptr<ArisSonarMock> mock(new ArisSonarMock(config));
  if (Status s = mock->open(); !s.ok()) return Error{"ARIS sonar mock: " + s.error().message};
  ArisSonarMock* raw = mock.get();
  mock->thread_.start([raw](std::vector<pollfd>& fds) { raw->collect(fds); },
                      [raw](const std::vector<pollfd>& fds) { raw->onReady(fds); });
  return mock;
}

ArisSonarMock::ArisSonarMock(ArisSonarMockConfig config) : config_(config), rng_(config.seed) {
  settings_.stream.packet_loss_mitigation = config_.sender.mode;
}

ArisSonarMock::~ArisSonarMock() {
  thread_.stop();
  closeFd(client_fd_);
  closeFd(listen_fd_);
  closeFd(data_fd_);
  closeFd(beacon_fd_);
  closeFd(timer_fd_);
}

Status ArisSonarMock::open() {
  data_fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (data_fd_ < 0) return Error{errnoText("frame socket")};
  const sockaddr_in data_addr = loopbackAddress(config_.ack_port);
  if (::bind(data_fd_, reinterpret_cast<const sockaddr*>(&data_addr), sizeof(data_addr)) != 0) {
    return Error{errnoText("ack_port " + std::to_string(config_.ack_port) + " bind")};
  }
  auto ack_port = boundPort(data_fd_, "frame socket");
  if (!ack_port.ok()) return ack_port.error();
  ack_port_ = *ack_port;

  beacon_fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (beacon_fd_ < 0) return Error{errnoText("beacon socket")};
  timer_fd_ = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
  if (timer_fd_ < 0) return Error{errnoText("timerfd")};

  command_port_ = config_.command_port;
  if (Status s = listen(); !s.ok()) return s;
  resetSender();
  next_beacon_s_ = monotonicNow_s();
  return Status::success();
}

Status ArisSonarMock::listen() {
  int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return Error{errnoText("command socket")};
  // Rebinding the same port after a reboot while old connections sit in TIME_WAIT.
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  const sockaddr_in addr = loopbackAddress(command_port_);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0 || ::listen(fd, kListenBacklog) != 0) {
    Error e{errnoText("command_port " + std::to_string(command_port_) + " bind/listen")};
    ::close(fd);
    return e;
  }
  auto port = boundPort(fd, "command socket");
  if (!port.ok()) {
    ::close(fd);
    return port.error();
  }
  command_port_ = *port;
  listen_fd_ = fd;
  return Status::success();
}

// ---------------------------------------------------------------------------- public members

Status ArisSonarMock::ping(const sonar::SonarFrame& frame, std::int64_t stamp_ns) {
  Status result;
  thread_.call([&] { result = pingOnThread(frame, stamp_ns); });
  return result;
}

Status ArisSonarMock::setFaults(const ArisLinkFaults& faults) {
  if (!inUnitInterval(faults.loss)) return Error{"loss: " + std::to_string(faults.loss) + ", must be in [0, 1]"};
  if (!inUnitInterval(faults.duplicate)) {
    return Error{"duplicate: " + std::to_string(faults.duplicate) + ", must be in [0, 1]"};
  }
  if (!inUnitInterval(faults.reorder)) {
    return Error{"reorder: " + std::to_string(faults.reorder) + ", must be in [0, 1]"};
  }
  thread_.call([&] { faults_ = faults; });
  return Status::success();
}

ArisLinkFaults ArisSonarMock::faults() const {
  ArisLinkFaults out;
  thread_.call([&] { out = faults_; });
  return out;
}

Status ArisSonarMock::reboot(double down_s) {
  if (!(down_s >= 0.0 && down_s <= 3600.0)) {
    return Error{"reboot down time: " + std::to_string(down_s) + " s, must be in [0, 3600]"};
  }
  thread_.call([&] {
    const double now = monotonicNow_s();
    disconnect();
    closeFd(listen_fd_);
    settings_ = ArisMockSettings{};
    settings_.stream.packet_loss_mitigation = config_.sender.mode;
    next_frame_index_ = 1;
    resetSender();
    down_until_s_ = now + down_s;
    ++stats_.reboots;
  });
  return Status::success();
}

ArisSonarMockStats ArisSonarMock::stats() const {
  ArisSonarMockStats out;
  thread_.call([&] {
    out = stats_;
    ArisFrameSenderStats sum = retired_sender_stats_;
    addSenderStats(sum, sender_->stats());
    out.frames_sent = sum.frames_sent;
    out.frames_finished = sum.frames_finished;
    out.frames_given_up = sum.frames_given_up;
    out.datagrams_resent = sum.datagrams_resent;
  });
  return out;
}

ArisMockSettings ArisSonarMock::appliedSettings() const {
  ArisMockSettings out;
  thread_.call([&] {
    out = settings_;
    out.connected = client_fd_ >= 0;
    out.rebooting = down_until_s_.has_value();
  });
  return out;
}

// ------------------------------------------------------------------------------ device thread

void ArisSonarMock::collect(std::vector<pollfd>& fds) {
  if (listen_fd_ >= 0) fds.push_back(pollfd{listen_fd_, POLLIN, 0});
  if (client_fd_ >= 0) fds.push_back(pollfd{client_fd_, POLLIN, 0});
  fds.push_back(pollfd{data_fd_, POLLIN, 0});
  fds.push_back(pollfd{timer_fd_, POLLIN, 0});
  itimerspec spec{};  // all zero: disarmed
  if (const std::optional<double> deadline = nextDeadline()) {
    // An absolute time already past fires at once; it_value must not be zero (that disarms).
    const double at = std::max(*deadline, 1e-9);
    spec.it_value.tv_sec = static_cast<time_t>(std::floor(at));
    spec.it_value.tv_nsec = static_cast<long>((at - std::floor(at)) * 1e9);
  }
  ::timerfd_settime(timer_fd_, TFD_TIMER_ABSTIME, &spec, nullptr);
}

void ArisSonarMock::onReady(const std::vector<pollfd>& fds) {
  const double now = monotonicNow_s();
  // Descriptors as they were polled: handling one may close another (a disconnect).
  const int listen_fd = listen_fd_;
  const int client_fd = client_fd_;
  for (const pollfd& p : fds) {
    if (p.revents == 0) continue;
    if (p.fd == timer_fd_) {
      std::uint64_t expirations = 0;
      [[maybe_unused]] const ssize_t n = ::read(timer_fd_, &expirations, sizeof(expirations));
    } else if (p.fd == data_fd_) {
      readAcks(now);
    } else if (p.fd == client_fd && client_fd == client_fd_) {
      readClient(now);
    } else if (p.fd == listen_fd && listen_fd == listen_fd_) {
      acceptClient(now);
    }
  }
  onTimers(monotonicNow_s());
}

void ArisSonarMock::onTimers(double now_s) {
  if (down_until_s_ && now_s >= *down_until_s_) {
    if (listen().ok()) {
      down_until_s_.reset();
      next_beacon_s_ = now_s;
    } else {
      down_until_s_ = now_s + kRelistenRetryS;
    }
  }
  if (!down_until_s_ && config_.beacon_port != 0 && now_s >= next_beacon_s_) {
    sendBeacon();
    next_beacon_s_ += config_.beacon_period_s;
    if (next_beacon_s_ <= now_s) next_beacon_s_ = now_s + config_.beacon_period_s;
  }
  if (client_fd_ >= 0 && now_s - last_command_s_ >= config_.keepalive_timeout_s) {
    ++stats_.disconnects_keepalive;
    disconnect();
  }
  if (held_ && now_s - held_since_s_ >= kReorderHoldMaxS) {
    sendToReceiver(*held_);
    held_.reset();
  }
  if (const std::optional<double> due = sender_->nextDeadline(); due && now_s >= *due) {
    for (auto& d : sender_->poll(now_s)) transmit(std::move(d), now_s);
  }
}

std::optional<double> ArisSonarMock::nextDeadline() const {
  std::optional<double> next;
  const auto consider = [&next](double t) { next = next ? std::min(*next, t) : t; };
  if (down_until_s_) consider(*down_until_s_);
  if (!down_until_s_ && config_.beacon_port != 0) consider(next_beacon_s_);
  if (client_fd_ >= 0) consider(last_command_s_ + config_.keepalive_timeout_s);
  if (held_) consider(held_since_s_ + kReorderHoldMaxS);
  if (const std::optional<double> due = sender_->nextDeadline()) consider(*due);
  return next;
}

void ArisSonarMock::acceptClient(double now_s) {
  const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
  if (fd < 0) return;  // the client gave up before we accepted: nothing to do
  if (client_fd_ >= 0) {
    // One controlling client at a time, as the ARIS: the newcomer learns it by the closed connection
    // (and the BUSY beacon).
    ::close(fd);
    ++stats_.connections_refused_busy;
    return;
  }
  client_fd_ = fd;
  decoder_.emplace();
  last_command_s_ = now_s;  // the keep-alive timer starts at the connection
  ++stats_.connections;
}

void ArisSonarMock::readClient(double now_s) {
  std::array<std::uint8_t, kCommandReadBytes> buf{};
  while (client_fd_ >= 0) {
    const ssize_t n = ::read(client_fd_, buf.data(), buf.size());
    if (n == 0) {  // the client closed the connection
      disconnect();
      return;
    }
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
      disconnect();
      return;
    }
    for (const sonar::ArisDecodedCommand& m : decoder_->feed(std::span<const std::uint8_t>(buf.data(), n))) {
      last_command_s_ = now_s;
      if (m.refusal) {
        ++stats_.commands_refused[static_cast<std::size_t>(*m.refusal)];
        if (sonar::arisCommandRefusalClosesStream(*m.refusal)) {
          ++stats_.disconnects_stream_broken;
          disconnect();
          return;
        }
        continue;
      }
      if (const auto check = sonar::validateArisCommand(*m.command, config_.model)) {
        ++stats_.commands_refused[static_cast<std::size_t>(check->reason)];
        continue;
      }
      applyCommand(*m.command);
      ++stats_.commands_applied;
    }
    if (decoder_->closed()) {  // a length prefix out of bounds with no message delivered
      ++stats_.disconnects_stream_broken;
      disconnect();
      return;
    }
  }
}

void ArisSonarMock::applyCommand(const sonar::ArisCommand& command) {
  std::visit(
      [this](const auto& c) {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, sonar::ArisSetDateTime>) {
          settings_.date_time = c.date_time;
        } else if constexpr (std::is_same_v<T, sonar::ArisSetFrameStreamReceiver>) {
          if (c.ip == "0.0.0.0") {
            settings_.receiver.reset();
            resetSender();
          } else {
            settings_.receiver = c;
          }
        } else if constexpr (std::is_same_v<T, sonar::ArisSetFrameStreamSettings>) {
          const bool mode_changed = c.packet_loss_mitigation != settings_.stream.packet_loss_mitigation;
          settings_.stream = c;
          if (mode_changed) resetSender();
        } else if constexpr (std::is_same_v<T, sonar::ArisAcousticSettings>) {
          settings_.acoustics = c;
        } else if constexpr (std::is_same_v<T, sonar::ArisSetSalinity>) {
          settings_.salinity = c.salinity;
        } else if constexpr (std::is_same_v<T, sonar::ArisSetFocus>) {
          settings_.focus_range_m = c.focus_range_m;
        } else {
          static_assert(std::is_same_v<T, sonar::ArisPing>);  // keep-alive: the time is already noted
        }
      },
      command);
}

void ArisSonarMock::disconnect() {
  if (client_fd_ < 0) return;
  closeFd(client_fd_);
  decoder_.reset();
  settings_.receiver.reset();
  resetSender();
}

void ArisSonarMock::resetSender() {
  if (sender_) {
    addSenderStats(retired_sender_stats_, sender_->stats());
    // A frame still awaiting acks is abandoned with its sender.
    if (sender_->inFlight()) ++retired_sender_stats_.frames_given_up;
  }
  ArisFrameSenderConfig sc = config_.sender;
  sc.mode = settings_.stream.packet_loss_mitigation;
  sc.ack_port = ack_port_;
  sender_ = std::make_unique<ArisFrameSender>(sc);
  held_.reset();
}

void ArisSonarMock::readAcks(double now_s) {
  std::array<std::uint8_t, kAckReadBytes> buf{};
  for (;;) {
    const ssize_t n = ::recv(data_fd_, buf.data(), buf.size(), 0);
    if (n < 0) return;  // EAGAIN: all read (ICMP errors of earlier sends end up here too)
    ++stats_.acks_received;
    if (draw(faults_.loss)) {
      ++stats_.acks_lost;
      continue;
    }
    sender_->onAck(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)), now_s);
  }
}

void ArisSonarMock::sendBeacon() {
  const sonar::ArisAvailability beacon{.serial_number = config_.serial_number,
                                       .system_type = config_.model,
                                       .version_major = config_.version_major,
                                       .version_minor = config_.version_minor,
                                       .version_build = config_.version_build,
                                       .busy = client_fd_ >= 0,
                                       .capabilities = {}};
  const std::vector<std::uint8_t> bytes = sonar::encodeArisAvailability(beacon);
  const sockaddr_in addr = loopbackAddress(config_.beacon_port);
  const ssize_t n =
      ::sendto(beacon_fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
  if (n == static_cast<ssize_t>(bytes.size())) {
    ++stats_.beacons_sent;
  } else {
    ++stats_.send_errors;
  }
}

bool ArisSonarMock::draw(double probability) {
  // No draw for a fault that is off, so turning one fault on does not change the others' sequence.
  if (probability <= 0.0) return false;
  return std::uniform_real_distribution<double>(0.0, 1.0)(rng_) < probability;
}

void ArisSonarMock::transmit(std::vector<std::uint8_t> datagram, double now_s) {
  if (draw(faults_.loss)) {
    ++stats_.datagrams_lost;
    return;
  }
  const int copies = draw(faults_.duplicate) ? 2 : 1;
  if (copies == 2) ++stats_.datagrams_duplicated;
  for (int i = 0; i < copies; ++i) {
    if (held_) {
      sendToReceiver(datagram);
      sendToReceiver(*held_);
      held_.reset();
    } else if (draw(faults_.reorder)) {
      held_ = datagram;
      held_since_s_ = now_s;
      ++stats_.datagrams_reordered;
    } else {
      sendToReceiver(datagram);
    }
  }
}

void ArisSonarMock::sendToReceiver(const std::vector<std::uint8_t>& datagram) {
  if (!settings_.receiver) return;  // the stream stopped while the datagram was held
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(settings_.receiver->port));
  if (::inet_pton(AF_INET, settings_.receiver->ip.c_str(), &addr.sin_addr) != 1) {
    ++stats_.send_errors;  // validateArisCommand accepted it, so this does not happen
    return;
  }
  const ssize_t n =
      ::sendto(data_fd_, datagram.data(), datagram.size(), 0, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr));
  if (n == static_cast<ssize_t>(datagram.size())) {
    ++stats_.datagrams_sent;
  } else {
    ++stats_.send_errors;
  }
}

Status ArisSonarMock::pingOnThread(const sonar::SonarFrame& frame, std::int64_t stamp_ns) {
  ++stats_.pings;
  const auto skip = [this](ArisPingSkip why) { ++stats_.pings_skipped[static_cast<std::size_t>(why)]; };
  if (frame.n_beams < 1 || frame.n_samples < 1 ||
      frame.samples.size() != static_cast<std::size_t>(frame.n_beams) * static_cast<std::size_t>(frame.n_samples) ||
      !(frame.window_length_m > 0.0) || !std::isfinite(frame.window_length_m) || !std::isfinite(frame.window_start_m)) {
    skip(ArisPingSkip::kFrameInvalid);
    return Error{"ARIS sonar mock: input frame " + std::to_string(frame.n_beams) + " beams x " +
                 std::to_string(frame.n_samples) + " samples with " + std::to_string(frame.samples.size()) +
                 " bytes, window length " + std::to_string(frame.window_length_m) + " m: not a frame"};
  }
  if (down_until_s_) {
    skip(ArisPingSkip::kRebooting);
    return Status::success();
  }
  if (!settings_.receiver) {
    skip(ArisPingSkip::kNoReceiver);
    return Status::success();
  }
  if (!settings_.acoustics) {
    skip(ArisPingSkip::kNoSettings);
    return Status::success();
  }
  const sonar::ArisAcousticSettings& acoustics = *settings_.acoustics;
  if (!acoustics.enable_transmit) {
    skip(ArisPingSkip::kTransmitOff);
    return Status::success();
  }
  const auto beams = sonar::arisBeamsForPingMode(acoustics.ping_mode);
  if (!beams.ok()) {  // validateArisCommand refuses such settings: kept for safety
    skip(ArisPingSkip::kSendFailed);
    return Error{"ARIS sonar mock: " + beams.error().message};
  }
  const double now = monotonicNow_s();
  // Acks that arrived before this ping may finish the previous frame: the sender gives a frame in
  // flight up when the next one is sent. Posted work (this ping) runs before the poll results.
  readAcks(now);
  sonar::SonarFrame out = arisSettingsFrame(frame, *beams, acoustics, config_.sound_speed_mps, config_.background);
  out.frame_index = next_frame_index_;
  out.stamp_ns = stamp_ns;
  auto datagrams = sender_->send(out,
                                 {.ping_mode = acoustics.ping_mode,
                                  .reordered_samples = false,
                                  .settings_cookie = acoustics.cookie,
                                  .salinity = static_cast<std::uint32_t>(settings_.salinity)},
                                 now);
  if (!datagrams.ok()) {
    skip(ArisPingSkip::kSendFailed);
    return Error{"ARIS sonar mock: frame " + std::to_string(next_frame_index_) + ": " + datagrams.error().message};
  }
  ++next_frame_index_;
  for (auto& d : *datagrams) transmit(std::move(d), now);
  return Status::success();
}

}  // namespace vog::mock
