#include "vog/app/device_source.hpp"

#include "vog/depth/digiquartz.hpp"
#include "vog/imu/imu_can.hpp"
#include "vog/io/can.hpp"
#include "vog/io/serial.hpp"
#include "vog/io/tcp_client.hpp"
#include "vog/io/udp.hpp"
#include "vog/sonar/aris_availability.hpp"
#include "vog/sonar/aris_command.hpp"

#include <asio/executor_work_guard.hpp>
#include <asio/io_context.hpp>
#include <asio/post.hpp>
#include <asio/steady_timer.hpp>

#include <chrono>
#include <cmath>
#include <functional>

namespace vog::app {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::chrono::milliseconds kTick{50};
// The depth sensor streams after *0100P4; when nothing came for this long (simulated time) it is
// asked again (a sensor that was power-cycled comes back in polled mode).
constexpr std::int64_t kDepthRestartNs = 2'000'000'000;

std::vector<std::uint8_t> bytesOf(const std::string& s) { return {s.begin(), s.end()}; }

backseat::TimeOfDay utcTimeOfDay() {
  const auto since_epoch = std::chrono::system_clock::now().time_since_epoch();
  const double s = std::chrono::duration<double>(since_epoch).count();
  return {std::fmod(s, 86400.0)};
}

api::DeviceState stateOf(const io::DeviceHealth& h, bool data_stale) {
  switch (h.state) {
    case io::LinkState::kDisconnected: return api::DeviceState::kDisconnected;
    case io::LinkState::kConnecting: return api::DeviceState::kDisconnected;
    case io::LinkState::kConnected: return data_stale ? api::DeviceState::kDegraded : api::DeviceState::kOk;
  }
  return api::DeviceState::kFailed;
}

}  // namespace

struct DeviceSource::Impl {
  Impl(const DevicesSection& c, DeviceFeed f, const backseat::LocalTangentPlane& ltp,
       std::optional<sonar::ArisDerivedSettings> aris)
      : config(c), feed(std::move(f)), follower(followerConfig(c), ltp), aris_settings(std::move(aris)) {
    aris_address = c.aris.address;
  }

  static WaypointFollowerConfig followerConfig(const DevicesSection& c) {
    WaypointFollowerConfig f = c.follower;
    f.expect_acks = c.backseat_enabled;
    return f;
  }

  std::int64_t now() const {
    const auto t = std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
    return static_cast<std::int64_t>(static_cast<long double>(t) * static_cast<long double>(config.time_scale));
  }
  io::StampClock stampClock() {
    return [this] { return now(); };
  }

  // Source thread: the raw log first, then decoding; scans may block on the mapping queue.
  void onChunk(DeviceId device, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes) {
    if (stopping.load()) return;
    sink->onRawBytes(static_cast<std::uint16_t>(device), stamp_ns, bytes);
    output.clear();
    feed.feed(device, stamp_ns, bytes, output);
    for (const OdometrySample& o : output.odometry) {
      sink->onOdometry(o);
      if (!backseat) {
        // No vehicle navigation to follow: arrival is judged on this daemon's odometry.
        VehicleNavigation own;
        own.stamp_ns = o.stamp_ns;
        own.T_world_vehicle = o.T_odom_vehicle;
        own.velocity_world_mps = feed.deadReckoning(o.stamp_ns).velocity_world_mps;
        follower.onNavigation(own, o.T_odom_vehicle);
      }
    }
    for (const backseat::AckSentence& a : output.acks) follower.onAck(a);
    if (output.vehicle_navigation) {
      auto T = feed.odometryPoseAt(output.vehicle_navigation->stamp_ns);
      follower.onNavigation(*output.vehicle_navigation, T ? std::optional<geometry::Pose3>(*T) : std::nullopt);
    }
    if (sonar && !aris_address.empty()) {
      for (const ArisAckOut& ack : output.aris_acks) {
        (void)sonar->sendTo(aris_address, static_cast<std::uint16_t>(ack.port), ack.datagram);
      }
    }
    for (const slam::ScanInput& scan : output.scans) {
      if (!sink->onScan(scan, std::nullopt)) return;
    }
  }

  // ---- ARIS: the command channel ----

  bool arisKind() const { return config.sonar_kind == SonarKind::kAris; }

  void openArisCommands() {
    io::TcpClientConfig c;
    c.address = aris_address;
    c.port = config.aris.command_port;
    c.reconnect = config.aris.reconnect;
    aris_commands = std::make_unique<io::TcpClient>(
        io, c, stampClock(), [](std::span<const std::uint8_t>, std::int64_t) {},  // the sonar sends nothing here
        [this](const io::DeviceHealth& h) {
          aris_setup_pending = h.state == io::LinkState::kConnected;
          sendArisSetup();
        });
  }

  // Sends one command; every command but PING goes to the raw log and the feed (the cookie).
  void sendAris(const sonar::ArisCommand& command) {
    const std::vector<std::uint8_t> bytes = sonar::encodeArisCommand(command);
    if (Status s = aris_commands->write(bytes); !s.ok()) return;  // the link reconnects and sends it all again
    if (!std::holds_alternative<sonar::ArisPing>(command)) onChunk(DeviceId::kArisCommands, now(), bytes);
  }

  // On every (re)connection: the date, the stream settings, the acoustic settings, the receiver;
  // once the frame receiver is bound (its port goes to the sonar), so perhaps from a later tick.
  void sendArisSetup() {
    if (!aris_setup_pending || sonar->localPort() == 0) return;
    aris_setup_pending = false;
    sonar::ArisDerivedSettings settings = *aris_settings;
    aris_cookies.stamp(settings.acoustic);
    const std::string& receiver =
        config.aris.receiver_address.empty() ? config.sonar.bind_address : config.aris.receiver_address;
    const sonar::ArisSetFrameStreamReceiver to{receiver, sonar->localPort()};
    const auto unix_s =
        std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
    for (const sonar::ArisCommand& c : sonar::arisConnectCommands(settings, config.aris.stream, to, unix_s)) {
      sendAris(c);
    }
    aris_settings_sent_ns = now();
    aris_ping_ns = aris_settings_sent_ns;
  }

  void arisTick(std::int64_t t) {
    if (!aris_commands || aris_commands->health().state != io::LinkState::kConnected) return;
    sendArisSetup();
    if (1e-9 * static_cast<double>(t - aris_ping_ns) < config.aris.keepalive_period_s) return;
    aris_ping_ns = t;
    sendAris(sonar::ArisPing{});
  }

  // An Availability beacon: who the sonar is, and where (discovery when no address is configured).
  void onArisBeacon(std::span<const std::uint8_t> datagram) {
    auto beacon = sonar::decodeArisAvailability(datagram);
    if (!beacon) {
      ++aris_beacons_refused;
      aris_beacon_error = beacon.error().message;
      return;
    }
    if (config.aris.serial_number != 0 && beacon->serial_number != config.aris.serial_number) return;
    const std::string from = aris_beacon->senderAddress();
    if (!aris_address.empty() && from != aris_address) return;  // another sonar, or one not ours
    aris_identity = *beacon;
    if (aris_commands) return;
    aris_address = from;
    openArisCommands();
    (void)aris_commands->start();  // config validated: starting only schedules the connection
  }

  // The sonar's row in health: the frame stream and the command channel together.
  std::string arisDetail(std::int64_t t, api::DeviceState& state) const {
    std::string d;
    if (aris_identity) {
      const sonar::ArisAvailability& a = *aris_identity;
      const sonar::ArisModelLimits& m = sonar::arisModelLimits(a.system_type);
      d = std::string(m.name) + " serial " + std::to_string(a.serial_number) + " software " +
          std::to_string(a.version_major) + "." + std::to_string(a.version_minor) + "." +
          std::to_string(a.version_build) + " at " + aris_address;
      if (a.system_type != config.aris.sonar.model) {
        d += ": configured as an " + std::string(sonar::arisModelLimits(config.aris.sonar.model).name) +
             ", its settings may not be taken";
        state = api::DeviceState::kDegraded;
      }
    } else {
      d = std::string(sonar::arisModelLimits(config.aris.sonar.model).name) + " at " +
          (aris_address.empty() ? "(waiting for its beacon)" : aris_address);
    }
    if (aris_beacons_refused > 0) {
      d += " (" + std::to_string(aris_beacons_refused) + " beacons refused, last: " + aris_beacon_error + ")";
    }
    if (aris_commands == nullptr || aris_commands->health().state != io::LinkState::kConnected) {
      d += ", command channel " +
           (aris_commands == nullptr ? std::string("not open") : "down: " + aris_commands->health().reason);
      state = api::DeviceState::kDisconnected;
      return d;
    }
    const std::uint32_t sent = feed.arisCookieSent();
    const std::uint32_t got = feed.arisCookieReceived();
    if (sent != 0 && got == sent) {
      d += ", settings " + std::to_string(sent) + " applied";
    } else if (sent != 0) {
      const double waited_s = 1e-9 * static_cast<double>(t - aris_settings_sent_ns);
      d += ", settings " + std::to_string(sent) + " sent, " +
           (got == 0 ? std::string("no frame since") : "frames carry " + std::to_string(got));
      if (waited_s > config.aris.settings_timeout_s) {
        d += ": the sonar has not taken the acoustic settings sent";
        state = api::DeviceState::kDegraded;
      }
    }
    const sonar::ArisFrameAssemblerStats& a = feed.arisFrames();
    d += "; " + std::to_string(a.frames_completed) + " frames, " + std::to_string(a.frames_dropped_incomplete) +
         " incomplete, " + std::to_string(feed.arisFramesOtherSettings()) + " with other settings";
    return d;
  }

  void openDevices() {
    auto bytesTo = [this](DeviceId d) {
      return [this, d](std::span<const std::uint8_t> b, std::int64_t t) { onChunk(d, t, b); };
    };
    if (config.dvl_enabled) {
      dvl = std::make_unique<io::SerialTransport>(io, config.dvl, stampClock(), bytesTo(DeviceId::kDvl));
    }
    if (config.depth_enabled) {
      depth = std::make_unique<io::SerialTransport>(io, config.depth, stampClock(), bytesTo(DeviceId::kDepth),
                                                    [this](const io::DeviceHealth& h) {
                                                      if (h.state == io::LinkState::kConnected) startDepthStream();
                                                    });
    }
    if (config.imu_enabled) {
      imu =
          std::make_unique<io::CanTransport>(io, config.imu, stampClock(), [this](const can_frame& f, std::int64_t t) {
            const std::vector<std::uint8_t> bytes = imu::canFramesToBytes(std::span<const can_frame>(&f, 1));
            onChunk(DeviceId::kImu, t, bytes);
          });
    }
    if (config.sonar_enabled) {
      sonar = std::make_unique<io::UdpReceiver>(io, config.sonar, stampClock(),
                                                bytesTo(arisKind() ? DeviceId::kArisFrames : DeviceId::kSonar));
      if (arisKind() && !aris_address.empty()) openArisCommands();
      if (arisKind() && config.aris.beacon_port != 0) {
        io::UdpReceiverConfig b;
        b.bind_address = "0.0.0.0";  // beacons are broadcast
        b.port = config.aris.beacon_port;
        b.max_datagram_bytes = 4096;
        b.receive_buffer_bytes = 64 * 1024;
        b.reconnect = config.aris.reconnect;
        aris_beacon = std::make_unique<io::UdpReceiver>(
            io, b, stampClock(), [this](std::span<const std::uint8_t> d, std::int64_t) { onArisBeacon(d); });
      }
    }
    if (config.backseat_enabled) {
      backseat = std::make_unique<io::TcpClient>(io, config.backseat, stampClock(), bytesTo(DeviceId::kBackseat));
    }
  }

  Status startDevices() {
    if (dvl) {
      if (Status s = dvl->start(); !s.ok()) return Error{"devices.dvl: " + s.error().message};
    }
    if (depth) {
      if (Status s = depth->start(); !s.ok()) return Error{"devices.depth: " + s.error().message};
    }
    if (imu) {
      if (Status s = imu->start(); !s.ok()) return Error{"devices.imu: " + s.error().message};
    }
    if (sonar) {
      if (Status s = sonar->start(); !s.ok()) return Error{"devices.sonar: " + s.error().message};
    }
    if (aris_commands) {
      if (Status s = aris_commands->start(); !s.ok()) return Error{"devices.sonar.aris: " + s.error().message};
    }
    if (aris_beacon) {
      if (Status s = aris_beacon->start(); !s.ok())
        return Error{"devices.sonar.aris.beacon_port: " + s.error().message};
    }
    if (backseat) {
      if (Status s = backseat->start(); !s.ok()) return Error{"devices.backseat: " + s.error().message};
    }
    return {};
  }

  void startDepthStream() {
    const std::string p4 = depth::encodeCommand(1, 0, "P4");  // continuous readings
    (void)depth->write(bytesOf(p4));
    depth_asked_ns = now();
  }

  // Every tick on the source thread: waypoints in, backseat sentences out, health, the heartbeat.
  void tick() {
    ++heartbeat;
    std::optional<std::vector<SourceWaypoint>> waypoints;
    {
      const std::lock_guard lock(mutex);
      waypoints = std::exchange(pending, std::nullopt);
    }
    if (waypoints) follower.setWaypoints(std::move(*waypoints));
    const std::int64_t t = now();
    const std::vector<std::string> out = follower.poll(t, utcTimeOfDay(), 1, "vogd mapping");
    if (backseat && backseat->health().state == io::LinkState::kConnected) {
      for (const std::string& s : out) (void)backseat->write(bytesOf(s));
    }
    arisTick(t);
    if (depth && depth->health().state == io::LinkState::kConnected) {
      const std::int64_t last = feed.counters(DeviceId::kDepth).last_stamp_ns;
      if (t - std::max(last, depth_asked_ns) > kDepthRestartNs) startDepthStream();
    }
    std::vector<api::DeviceHealth> h = collectHealth(t);
    const std::optional<SourceObstruction> stopped = follower.takeObstruction();
    const std::lock_guard lock(mutex);
    health = std::move(h);
    follower_idle = follower.idle();
    if (stopped) obstruction = stopped;
  }

  std::vector<api::DeviceHealth> collectHealth(std::int64_t t) const {
    std::vector<api::DeviceHealth> out;
    auto add = [&](DeviceId d, const io::DeviceHealth* link, double timeout_s, std::string detail) {
      if (link == nullptr) return;
      const DeviceCounters& c = feed.counters(d);
      const bool stale = c.last_stamp_ns < 0 || 1e-9 * static_cast<double>(t - c.last_stamp_ns) > timeout_s;
      api::DeviceHealth h;
      h.name = toString(d);
      h.state = stateOf(*link, stale);
      h.last_stamp_ns = c.last_stamp_ns;
      h.messages = c.messages;
      h.errors = c.rejected + feed.droppedInput(d) + link->errors;
      if (link->state != io::LinkState::kConnected) detail = link->reason + (detail.empty() ? "" : "; " + detail);
      if (!c.last_error.empty()) detail += (detail.empty() ? "" : "; ") + std::string("last rejected: ") + c.last_error;
      h.detail = detail;
      out.push_back(std::move(h));
    };
    const nav::DeadReckoningConfig& n = config.feed.nav;
    add(DeviceId::kDvl, dvl ? &dvl->health() : nullptr, n.dvl_timeout_s, "");
    add(DeviceId::kDepth, depth ? &depth->health() : nullptr, n.depth_timeout_s, "");
    add(DeviceId::kImu, imu ? &imu->health() : nullptr, n.imu_timeout_s, "");
    const std::string scans = std::to_string(feed.scans()) + " scans, " + std::to_string(feed.scansDropped()) +
                              " dropped" + (feed.scansDropped() > 0 ? " (last: " + feed.lastDropReason() + ")" : "");
    if (arisKind()) {
      api::DeviceState state = api::DeviceState::kOk;
      const std::string detail = arisDetail(t, state);
      add(DeviceId::kArisFrames, sonar ? &sonar->health() : nullptr, 2.0, detail + "; " + scans);
      if (!out.empty()) {
        api::DeviceHealth& row = out.back();
        row.name = "sonar";
        // The command channel down outranks the stream; settings not taken degrade a working one.
        if (state == api::DeviceState::kDisconnected ||
            (state == api::DeviceState::kDegraded && row.state == api::DeviceState::kOk)) {
          row.state = state;
        }
      }
    } else {
      add(DeviceId::kSonar, sonar ? &sonar->health() : nullptr, 2.0, scans);
    }
    if (backseat) {
      const FollowerStats& f = follower.stats();
      std::string detail = std::to_string(f.commands_sent) + " waypoints sent, " + std::to_string(f.arrived) +
                           " reached, " + std::to_string(f.refused) + " refused";
      if (!follower.lastError().empty()) detail += " (last: " + follower.lastError() + ")";
      add(DeviceId::kBackseat, &backseat->health(), 2.0, detail);
    }
    // Navigation as a whole: dead reckoning's own health.
    if (config.feed.navigation == NavigationSource::kDeadReckoning) {
      const nav::NavSolution s = feed.deadReckoning(t);
      api::DeviceHealth h;
      h.name = "navigation";
      h.last_stamp_ns = t;
      h.messages = s.dvl_used;
      h.errors = s.dvl_rejected + s.imu_rejected + s.depth_rejected;
      const bool waiting = config.feed.align_to_vehicle && !feed.aligned();
      h.state = s.degraded || waiting ? api::DeviceState::kDegraded : api::DeviceState::kOk;
      h.detail = s.degraded ? s.reason
                 : waiting  ? "waiting for the vehicle's navigation ($BFNVG) to align dead reckoning"
                            : "dead reckoning, position sigma " + std::to_string(s.position_sigma_m) + " m";
      out.push_back(std::move(h));
    }
    return out;
  }

  void scheduleTick() {
    timer.expires_after(kTick);
    timer.async_wait([this](const std::error_code& ec) {
      if (ec || stopping.load()) return;
      tick();
      scheduleTick();
    });
  }

  const DevicesSection config;
  asio::io_context io;
  asio::steady_timer timer{io};
  std::thread thread;
  SourceSink* sink = nullptr;
  std::atomic<bool> stopping{false};
  std::atomic<std::uint64_t> heartbeat{0};

  // Source thread only.
  DeviceFeed feed;
  FeedOutput output;
  WaypointFollower follower;
  std::unique_ptr<io::SerialTransport> dvl, depth;
  std::unique_ptr<io::CanTransport> imu;
  std::unique_ptr<io::UdpReceiver> sonar;
  std::unique_ptr<io::TcpClient> backseat;
  std::int64_t depth_asked_ns = 0;
  // ARIS (kind aris): the command channel, the settings it sends and their cookies.
  std::unique_ptr<io::TcpClient> aris_commands;
  std::optional<sonar::ArisDerivedSettings> aris_settings;  // derived from the config at create()
  // Counted from the start time: the sonar may still hold the settings of a vogd run before.
  sonar::ArisSettingsCookies aris_cookies{sonar::arisFirstCookie(
      std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count())};
  std::string aris_address;  // configured, or the beacon's sender
  std::unique_ptr<io::UdpReceiver> aris_beacon;
  std::optional<sonar::ArisAvailability> aris_identity;  // the newest beacon of our sonar
  std::uint64_t aris_beacons_refused = 0;
  std::string aris_beacon_error;
  bool aris_setup_pending = false;  // connected, setup not sent yet
  std::int64_t aris_settings_sent_ns = 0;
  std::int64_t aris_ping_ns = 0;

  mutable std::mutex mutex;
  std::optional<std::vector<SourceWaypoint>> pending;  // guarded by mutex
  std::vector<api::DeviceHealth> health;               // guarded by mutex
  bool follower_idle = true;                           // guarded by mutex
  std::optional<SourceObstruction> obstruction;        // guarded by mutex
};

Result<std::unique_ptr<DeviceSource>> DeviceSource::create(const DevicesSection& config) {
  if (!(config.time_scale > 0.0)) return Error{"devices.time_scale must be positive"};
  if (config.backseat_enabled) {
    if (Status s = config.follower.validate(); !s.ok()) return s.error();
  }
  auto feed = DeviceFeed::create(config.feed);
  if (!feed) return feed.error();
  auto ltp = backseat::LocalTangentPlane::create(config.feed.origin);
  if (!ltp) return Error{"devices.backseat.origin: " + ltp.error().message};
  std::optional<sonar::ArisDerivedSettings> aris;
  if (config.sonar_enabled && config.sonar_kind == SonarKind::kAris) {
    if (Status s = config.aris.validate(config.sonar.bind_address); !s.ok()) return s.error();
    aris = sonar::deriveArisAcousticSettings(config.aris.sonar).value();
  }
  auto impl = std::make_unique<Impl>(config, std::move(feed).value(), *ltp, std::move(aris));
  impl->openDevices();
  return std::unique_ptr<DeviceSource>(new DeviceSource(std::move(impl)));
}

DeviceSource::DeviceSource(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

DeviceSource::~DeviceSource() { stop(); }

Status DeviceSource::start(SourceSink& sink) {
  Impl& d = *impl_;
  if (d.thread.joinable()) return Error{"device source already started"};
  d.sink = &sink;
  if (Status s = d.startDevices(); !s.ok()) return s;
  d.scheduleTick();
  d.thread = std::thread([&d] {
    auto work = asio::make_work_guard(d.io);
    d.io.run();
  });
  return {};
}

void DeviceSource::stop() {
  Impl& d = *impl_;
  if (d.stopping.exchange(true)) return;
  if (!d.thread.joinable()) return;
  // The transports are stopped on their own thread; then the thread ends.
  asio::post(d.io, [&d] {
    d.timer.cancel();
    for (io::SerialTransport* s : {d.dvl.get(), d.depth.get()}) {
      if (s != nullptr) s->stop();
    }
    if (d.imu) d.imu->stop();
    if (d.sonar) d.sonar->stop();
    if (d.aris_commands) d.aris_commands->stop();
    if (d.aris_beacon) d.aris_beacon->stop();
    if (d.backseat) d.backseat->stop();
    d.io.stop();
  });
  d.thread.join();
}

Status DeviceSource::setWaypoints(std::vector<SourceWaypoint> waypoints) {
  for (const SourceWaypoint& w : waypoints) {
    if (!w.p_odom_m.allFinite() || !std::isfinite(w.yaw_rad)) return Error{"waypoint is not finite"};
  }
  const std::lock_guard lock(impl_->mutex);
  impl_->pending = std::move(waypoints);
  impl_->follower_idle = false;
  return {};
}

bool DeviceSource::idle() const {
  const std::lock_guard lock(impl_->mutex);
  return !impl_->pending && impl_->follower_idle;
}

std::vector<api::DeviceHealth> DeviceSource::health() const {
  const std::lock_guard lock(impl_->mutex);
  return impl_->health;
}

std::uint64_t DeviceSource::heartbeat() const { return impl_->heartbeat.load(); }

std::optional<SourceObstruction> DeviceSource::takeObstruction() {
  const std::lock_guard lock(impl_->mutex);
  return std::exchange(impl_->obstruction, std::nullopt);
}

}  // namespace vog::app
