#pragma once
// SimSource: the built-in simulator as vogd's vehicle (config `source: sim`). A thread steps the
// lockstep simulation (sim/world) and hands odometry and sonar scans to the daemon; the simulated
// vehicle follows the daemon's waypoints as a real vehicle steering on its own dead reckoning would:
// a waypoint in the odometry frame is reached in truth through the current odometry error.
//
// Pacing: `speedup` simulated seconds per wall second; 0 = as fast as the daemon keeps up, and then
// simulated time stands still while the vehicle waits for a waypoint (at most max_idle_wait of wall
// time per step, so a daemon that never answers cannot stall it for good).
// Lifecycle: create() loads the scene and places the vehicle (at the scene's start, or at `start`
// when resuming a mission); start(sink) runs the thread; stop() joins it. A simulator error stops the
// thread and is reported by failure() and health().

#include "vog/app/vehicle_source.hpp"
#include "vog/app/vogd_config.hpp"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

namespace vog::sim {
class World;
class LockstepSimulation;
}  // namespace vog::sim

namespace vog::app {

class SimSource final : public VehicleSource {
 public:
  // `start` replaces the scene's start pose (x, y, z, yaw).
  static Result<std::unique_ptr<SimSource>> create(const SimSection& config,
                                                   const std::optional<geometry::Pose3>& start = std::nullopt);
  ~SimSource() override;

  Status start(SourceSink& sink) override;
  void stop() override;
  Status setWaypoints(std::vector<SourceWaypoint> waypoints) override;
  bool idle() const override;
  std::vector<api::DeviceHealth> health() const override;
  std::uint64_t heartbeat() const override { return heartbeat_.load(); }
  Status failure() const override;
  std::optional<SourceObstruction> takeObstruction() override;  // a move the collision check refused

  // Collisions the simulated vehicle suffered (it stops short of the scene; a planner bug if > 0).
  std::uint64_t collisions() const { return collisions_.load(); }
  double simSeconds() const { return 1e-9 * static_cast<double>(stamp_ns_.load()); }
  double pathLengthM() const;

  static constexpr std::chrono::milliseconds kMaxIdleWait{2000};

 private:
  SimSource(const SimSection& config, std::unique_ptr<sim::World> world);
  void run(SourceSink& sink);

  const SimSection config_;
  std::unique_ptr<sim::World> world_;
  std::unique_ptr<sim::LockstepSimulation> simulation_;  // sim thread only after start()

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<std::vector<SourceWaypoint>> pending_;  // guarded by mutex_
  bool stopping_ = false;                               // guarded by mutex_
  std::optional<Error> failure_;                        // guarded by mutex_
  double path_length_m_ = 0.0;                          // guarded by mutex_
  std::optional<SourceObstruction> obstruction_;        // guarded by mutex_
  std::atomic<bool> vehicle_idle_{true};
  std::atomic<std::uint64_t> heartbeat_{0};
  std::atomic<std::uint64_t> scans_{0};
  std::atomic<std::uint64_t> collisions_{0};
  std::atomic<std::int64_t> stamp_ns_{0};
  std::thread thread_;
};

}  // namespace vog::app
