#pragma once
// The simulated vehicle behind mock devices: the lockstep simulation of
// sim/world paced at `speedup` times wall time, its samples put on the real wire protocols by
// the mock devices of drivers/mock, and the backseat link closing the loop:
//   DVL    PD0 ensembles (bottom track, instrument frame) on a pseudo-terminal, 5 Hz
//   depth  Digiquartz replies on a pseudo-terminal (P3 polled, or every sample after P4), 10 Hz
//   IMU    CAN frames (drivers/imu/README.md) on the Unix-domain SOCK_SEQPACKET stand-in, 100 Hz
//   sonar  one rendered frame per ping, 5 Hz: with sonar_kind kFragments as fragment datagrams
//          (sonar_udp.hpp) to 127.0.0.1:sonar_port; with kAris through a mock ARIS
//          (mock::ArisSonarMock) that a client controls on the ARIS live protocol and that sends
//          the frame its acoustic settings describe to the receiver the client names
//   backseat  TCP server: $BFNVG + $BFNVR (the vehicle's navigation estimate) at nav_sentence_rate_hz;
//          $BPGHP go-to-position commands acknowledged with $BFACK and followed; $BPSTS counted.
// All rates are in simulated time.
//
// Go-to-position semantics (as the HAUV backseat does): a new accepted command replaces the current
// target at once (no queue). The target is given in the vehicle's navigation frame (the one its
// $BFNVG reports, which drifts from the truth by the odometry error); it is mapped into the true
// world with the navigation error at the time of the command, so the vehicle ends where its own
// navigation says the target is. With the optional heading field the vehicle turns to that heading
// (also a navigation-frame value) while it moves and holds it on arrival; without it, it turns to
// face the target while it moves when the target is more than `face_target_min_distance_m` away
// horizontally, else it keeps its heading.
// The speed field is capped by the vehicle's speed limit (slower speeds are not modelled). A
// command is rejected ($BFACK status 0 with the reason) when a value is not finite, the depth is
// negative, or the target is more than `operating_margin_m` outside the scene's box. A move the
// collision check refuses stops the vehicle where it is until the next command (event reported).
//
// Faults (control.hpp): `fault D kind s` gives every message of device D the fault for s simulated
// seconds (a polled depth sensor may carry one armed fault into its next reply after the window);
// `unplug D s` makes the device disappear (pty closed and link removed, server closed, sonar
// silent) and return after s simulated seconds. The ARIS sonar has its own faults instead
// (`aris loss|dup|reorder P`, `aris reboot s`, applied at once); `fault sonar` and `unplug sonar`
// are refused with it.
//
// Lifecycle: create() builds the simulation and opens every device (all listening); start()
// fixes the time base (simulated 0 = now) and launches the simulation thread; stop() (or
// destruction, or duration_s elapsing) ends it; devices close on destruction. Threading: every
// public member may be called from any thread; the simulation, the vehicle model and the device
// sends run on the simulation thread only; control() and backseat input are queued to it.
// Invariants: samples leave in stamp order, each at its wall time t0 + stamp / speedup (late when
// the thread falls behind, never early); the simulation is deterministic per seed, whatever the
// pacing (only the times at which commands arrive depend on the wall clock).

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "vog/core/result.hpp"
#include "vog/geometry/sonar.hpp"
#include "vog/mock/aris_sonar_mock.hpp"
#include "vog/vehicle/sim_wire.hpp"
#include "vog/sim/lockstep.hpp"
#include "vog/sim/world.hpp"
#include "vog/vehicle/endpoints.hpp"

namespace vog::vehicle {

struct SimVehicleConfig {
  std::uint64_t seed = 1;
  double speedup = 1.0;                 // simulated seconds per wall second, (0, 1000]
  double duration_s = 0.0;              // simulated time limit, 0 = until stop()
  std::filesystem::path run_dir;        // existing folder for the pty links (dvl, depth) and imu.sock
  std::uint16_t backseat_port = 29500;  // PROTOCOLS.md default; 0 = any free port
  SonarKind sonar_kind = SonarKind::kFragments;
  std::uint16_t sonar_port = 52102;  // kFragments: UDP destination on 127.0.0.1 (config/vogd.yaml default); 0 = off
  // kAris: the mock ARIS's command TCP port on 127.0.0.1 (0 = any free; a real ARIS uses 56888), the
  // UDP port on 127.0.0.1 its Availability beacon goes to (0 = no beacon; a real one: 56124) and its
  // serial number.
  std::uint16_t aris_command_port = 0;
  std::uint16_t aris_beacon_port = 0;
  std::uint32_t aris_serial_number = 1234;
  double nav_sentence_rate_hz = 5.0;  // $BFNVG + $BFNVR
  double origin_latitude_deg = 42.0;  // world (0, 0) for the backseat's positions
  double origin_longitude_deg = -71.0;
  double operating_margin_m = 5.0;  // accepted targets: the scene box grown by this
  double face_target_min_distance_m = 1.0;
  std::size_t history_steps = 3000;  // truth / scan / depth history kept for truthAt() etc.
  sim::LockstepConfig lockstep;      // its seed is replaced by `seed`; frame_every by the sonar
  SimWireConfig wire;

  // Names the first bad key and value, or is ok.
  Status validate() const;
};

struct VehicleSnapshot {
  std::int64_t stamp_ns = 0;  // simulated time of the newest step
  sim::VehicleState truth;
  geometry::Pose3 T_world_vehicle_nav = geometry::Pose3::Identity();  // what $BFNVG reports
  std::optional<Eigen::Vector3d> target_xyz_world;                    // true-world target of the current command
  std::uint32_t last_command_id = 0;
  std::uint64_t commands_accepted = 0;
  std::uint64_t commands_rejected = 0;
  std::uint64_t heartbeats = 0;
  std::uint64_t blocked_moves = 0;
  std::uint64_t scans = 0;  // sonar pings (each rendered and sent when the sonar is on)
  std::uint64_t dvl_sent = 0, imu_sent = 0, depth_sent = 0, nav_sentences_sent = 0;
  std::optional<mock::ArisSonarMockStats> aris;  // sonar kind kAris only
  double max_lag_ms = 0.0;                       // worst wall-clock lateness of a step
  double ping_step_ms_mean = 0.0;                // mean wall time of a step with a sonar ping (render + send)
  bool finished = false;                         // duration reached or stopped
};

// One simulated sample kept for comparison with what a receiver decoded.
struct StampedDepth {
  std::int64_t stamp_ns = 0;
  double depth_m = 0.0;
};

class SimVehicle {
 public:
  // Human-readable events (commands, faults, unplugs, blocked moves, lag) for the caller to log;
  // called on the simulation thread.
  using EventHandler = std::function<void(const std::string& event)>;

  // Borrows the World, which must outlive the vehicle.
  static Result<std::unique_ptr<SimVehicle>> create(const sim::World& world, SimVehicleConfig config,
                                                    EventHandler on_event = {});
  ~SimVehicle();
  SimVehicle(const SimVehicle&) = delete;
  SimVehicle& operator=(const SimVehicle&) = delete;

  Status start();
  void stop();
  // Waits until the run ends (duration reached or stopped) or the timeout passes; true if ended.
  bool waitFinished(std::chrono::milliseconds timeout) const;

  // Executes one control line (control.hpp); the reply is "ok ..." or an error naming what was wrong.
  Result<std::string> control(const std::string& line);

  // Endpoints of the run (time base valid after start()); scene_file and control_socket are the
  // caller's to fill.
  VehicleEndpoints endpoints() const;
  VehicleSnapshot snapshot() const;
  // Simulated time of the newest step (cheap; an in-process receiver's StampClock).
  std::int64_t simStampNs() const;
  // True state at a simulated stamp within the kept history (nearest step), or an error.
  Result<sim::VehicleState> truthAt(std::int64_t stamp_ns) const;
  // The simulator's own range scan of sonar frame `frame_index` (within the kept history).
  std::optional<geometry::RangeScan> scanOfFrame(std::uint32_t frame_index) const;
  // Simulated depth samples within [from_ns, to_ns] (within the kept history).
  std::vector<StampedDepth> depthSamples(std::int64_t from_ns, std::int64_t to_ns) const;

  class Impl;

 private:
  explicit SimVehicle(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace vog::vehicle
