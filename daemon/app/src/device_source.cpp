#include "vog/app/device_source.hpp"

#include "vog/depth/digiquartz.hpp"
#include "vog/imu/imu_can.hpp"
#include "vog/io/can.hpp"
#include "vog/io/serial.hpp"
#include "vog/io/tcp_client.hpp"
#include "vog/io/udp.hpp"

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
  Impl(const DevicesSection& c, DeviceFeed f, const backseat::LocalTangentPlane& ltp)
      : config(c), feed(std::move(f)), follower(followerConfig(c), ltp) {}

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
    for (const slam::ScanInput& scan : output.scans) {
      if (!sink->onScan(scan, std::nullopt)) return;
    }
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
      sonar = std::make_unique<io::UdpReceiver>(io, config.sonar, stampClock(), bytesTo(DeviceId::kSonar));
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
    add(DeviceId::kSonar, sonar ? &sonar->health() : nullptr, 2.0,
        std::to_string(feed.scans()) + " scans, " + std::to_string(feed.scansDropped()) + " dropped" +
            (feed.scansDropped() > 0 ? " (last: " + feed.lastDropReason() + ")" : ""));
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
  auto impl = std::make_unique<Impl>(config, std::move(feed).value(), *ltp);
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
