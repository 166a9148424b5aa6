#pragma once
// DeviceSource: the vehicle's real devices as vogd's vehicle (config `source: devices`). The
// transports of drivers/io (serial DVL and depth sensor, SocketCAN IMU, UDP sonar, TCP backseat) run
// on this source's own Asio io_context and thread; every chunk they receive is handed to the
// daemon's raw log (SourceSink::onRawBytes) and then decoded by a DeviceFeed into odometry and
// scans, in that order, so `vogd --replay` sees exactly what the live run decoded. Waypoints go to
// the vehicle over the backseat link (WaypointFollower: $BPGHP, acknowledgements, arrival by the
// vehicle's own navigation), with the $BPSTS heartbeat.
//
// Its own thread, not the API's io_context: onScan() blocks while mapping is behind, and that
// back-pressure must reach the devices (kernel buffers), never the API.
//
// Time: stamps are the monotonic clock times `devices.time_scale` (1 on a vehicle; a simulated
// vehicle running faster than real time sets its speed-up, so every rate is in its time). The
// monotonic clock keeps counting across a restart of vogd, so stamps only grow within a boot.
// Frames: the odometry frame is the vehicle's navigation frame (dead reckoning aligned to $BFNVG at
// start, or $BFNVG itself), which survives a restart of vogd (persistentFrame()).
// Faults: a device that disappears is reopened with backoff by its transport; malformed data is
// dropped and counted by its decoder; all of it shows in health().
//
// Lifecycle: create() validates; start(sink) opens every enabled device and starts the thread;
// stop() closes them and joins (idempotent). Threading: every public member may be called from any
// thread; transports, the feed and the follower live on the source thread only.

#include "vog/app/device_feed.hpp"
#include "vog/app/vehicle_source.hpp"
#include "vog/app/vogd_config.hpp"
#include "vog/app/waypoint_follower.hpp"

#include <memory>
#include <mutex>
#include <optional>
#include <thread>

namespace vog::app {

class DeviceSource final : public VehicleSource {
 public:
  static Result<std::unique_ptr<DeviceSource>> create(const DevicesSection& config);
  ~DeviceSource() override;

  Status start(SourceSink& sink) override;
  void stop() override;
  Status setWaypoints(std::vector<SourceWaypoint> waypoints) override;
  bool idle() const override;
  std::vector<api::DeviceHealth> health() const override;
  std::uint64_t heartbeat() const override;
  Status failure() const override { return {}; }                // devices fail and recover; health() says how
  std::optional<SourceObstruction> takeObstruction() override;  // a waypoint not reached in time
  bool persistentFrame() const override { return true; }

  struct Impl;

 private:
  explicit DeviceSource(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace vog::app
