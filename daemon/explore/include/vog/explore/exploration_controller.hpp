#pragma once
// ExplorationController: the closed loop's policy, once, for vogd and for `vog-bench mission`.
//
// It decides what the vehicle does during a mission, from what the caller hands it at each step:
//   start      a full turn on the spot when the map is empty (the vertical fan sees nothing ahead
//              until it has swept around, and the planner needs known free space to grow its tree);
//   explore    whenever the vehicle has reached its waypoints: a revisit when one is due (active
//              loop closure, slam::RevisitPolicy), else a next-best-view plan (plan::NbvPlanner);
//   obstructed the vehicle was stopped short: the planner hears of it (it backs the vehicle off and
//              marks the contact) and the vehicle holds until the next plan;
//   return     when the planner finds nothing left to explore (its plan is the way home), when the
//              submap budget is reached, or on the operator's word (returnHome()): the path home
//              from NbvPlanner::planHome, the one way home;
//   end        arrived home (kComplete, or kBudget when the budget cut the exploration short), arrived
//              at the reachable safe position nearest to a home that known free space does not reach
//              (kNearHome), no path on (kNoPath), or the planner kept answering without the vehicle
//              moving (kStalled).
// Events for the mission state machine (mission::MissionControl) come out with the step that
// caused them: kExplorationDone when it turns home, kArrivedHome, kArrivedNearHome, kNoPath. A caller whose operator
// can hold the mission between a step and its event (vogd: a pause the state machine answers by
// ignoring the event) asks eventsFor() instead, which says what the mission still has to hear.
//
// Frames: everything is in the map frame (the optimised estimate); the caller converts waypoints to
// whatever its vehicle steers in.
//
// Lifecycle: create() validates the configuration; start() begins a mission (again after an end or
// an abort: a new planner, the map kept); step() as often as the caller likes (vogd: every 50 ms
// and on every map change, in wall time; the bench: every simulation step, in lockstep); hold()
// when the caller stopped the vehicle (pause, abort, the operator's return home), so a path in
// progress is planned again. No threads, no clock (time is the stamps of the inputs), no I/O:
// deterministic for a given configuration (the planner's seed) and sequence of inputs. Not
// thread-safe: one thread owns it.

#include "vog/geometry/pose.hpp"
#include "vog/core/result.hpp"
#include "vog/map/merged_map.hpp"
#include "vog/mission/mission_control.hpp"
#include "vog/plan/nbv_planner.hpp"
#include "vog/slam/mapping_pipeline.hpp"
#include "vog/slam/revisit_policy.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace vog::explore {

struct ExplorationConfig {
  // The planner; its exploration box is the one start() is given.
  plan::PlannerConfig planner;
  // Active loop closure (revisits of old views); with loop closures only.
  bool revisits = false;
  slam::RevisitConfig revisit;
  // Submaps after which the exploration ends and the vehicle returns home (thesis Table 4.2: 156).
  int max_submaps = 156;
  // Plans in a row without the vehicle moving in between before the mission ends as stalled (our
  // choice: 50; a planner that answers with waypoints the vehicle is already at would loop forever).
  int max_idle_plans = 50;
  // Errors name the bad key.
  Status validate() const;
};

// How a mission ended.
enum class Ending { kNone, kComplete, kBudget, kNearHome, kNoPath, kStalled };
const char* toString(Ending ending);

// The vehicle was stopped short of its waypoint (map frame).
struct Obstruction {
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();       // where it stopped
  Eigen::Vector3d target_world = Eigen::Vector3d::Zero();  // where it was going
};

struct StepInput {
  std::int64_t stamp_ns = 0;                                      // the newest odometry stamp
  geometry::Pose3 T_world_vehicle = geometry::Pose3::Identity();  // the estimate, map frame
  bool vehicle_idle = false;                                      // every waypoint sent was reached
  std::optional<Obstruction> obstruction;                         // since the last step
  std::size_t n_submaps = 0;                                      // closed submaps
  // The map to plan on, asked for only when the step plans (a caller in lockstep synchronises with
  // its merge there, vogd running as fast as possible lets its mapping catch up first): the newest
  // merged snapshot, null when nothing is merged yet (the step then waits), or the caller's error.
  std::function<Result<std::shared_ptr<const map::MergedMap>>()> map;
  // The mapping side's submaps and accepted closures, for revisits (null: no revisit this step);
  // read during the call only.
  const std::vector<slam::SubmapRecord>* submaps = nullptr;
  const std::vector<slam::ClosurePair>* closures = nullptr;
};

struct StepOutput {
  // New waypoints for the vehicle, replacing its list (map frame); an empty list: hold position.
  // Unset: the vehicle goes on as it is.
  std::optional<std::vector<plan::Waypoint>> waypoints;
  // The planning iteration this step ran (exploration or the way home), for telemetry.
  std::optional<plan::PlanResult> plan;
  // What this step means for the mission state machine, and why (ExplorationController::summary()
  // when the mission ended, the planner's reason when it turned home).
  std::optional<mission::MissionEvent> event;
  std::string reason;
};

class ExplorationController {
 public:
  static Result<ExplorationController> create(const ExplorationConfig& config);

  // A new mission from `home` (map frame) inside `box`, at stamp `stamp_ns`; `map_empty`: nothing
  // is mapped yet, so the first step turns the vehicle on the spot. Errors: the planner's (home not
  // finite or outside the box, bad keys).
  Status start(const geometry::Pose3& T_world_home, const mission::Box& box, std::int64_t stamp_ns, bool map_empty);
  // The operator sends the vehicle home: the next step with the vehicle idle plans the way home.
  void returnHome();
  // The caller stopped the vehicle: the next step with the vehicle idle plans again.
  void hold();

  // One step of the loop (see above). Errors are the planner's (a pose outside the box, a map of
  // another resolution): the caller's inputs are wrong, the mission state is unchanged.
  Result<StepOutput> step(const StepInput& input);

  bool active() const { return planner_ != nullptr && ending_ == Ending::kNone; }
  bool returning() const { return returning_; }
  Ending ending() const { return ending_; }
  // Why the mission turned home or ended (the planner's reason).
  const std::string& reason() const { return reason_; }
  // The ending and its reason in one line ("no_path: ..."; "complete" alone when nothing is to be said).
  std::string summary() const;
  // The mission event the ending stands for (kArrivedHome, kArrivedNearHome, kNoPath); none while the
  // mission goes on.
  std::optional<mission::MissionEvent> endingEvent() const;
  // The events that bring a mission in `state` in line with this controller, in order: none while
  // the mission is held (paused) or over; kExplorationDone when it still explores but the controller
  // turned home; then the ending's event. Each of them changes `state` when applied in order.
  std::vector<mission::MissionEvent> eventsFor(mission::MissionState state) const;
  // The planner of the current mission (null before start()): its last tree and grid, for plots.
  const plan::NbvPlanner* planner() const { return planner_.get(); }
  int revisits() const { return revisit_ ? revisit_->revisits() : 0; }

 private:
  explicit ExplorationController(const ExplorationConfig& config) : config_(config) {}
  // Turns the mission home on `path` (the planner's kComplete or kNearHome result), or ends it when
  // there is none.
  void goHome(Ending why, const plan::PlanResult& path, StepOutput& out);
  void end(Ending ending, std::string reason, StepOutput& out);

  ExplorationConfig config_;
  std::unique_ptr<plan::NbvPlanner> planner_;
  std::optional<slam::RevisitPolicy> revisit_;
  bool spin_pending_ = false;               // start() on an empty map: turn on the spot first
  bool returning_ = false;                  // on the way home (or about to plan it)
  bool home_path_sent_ = false;             // the way home was handed to the vehicle
  Ending home_ending_ = Ending::kComplete;  // what arriving home ends the mission as
  bool short_of_home_ = false;              // the way home sent ends near home, not at it (kNearHome)
  Ending ending_ = Ending::kNone;
  std::string reason_;
  int idle_plans_ = 0;                        // plans since the vehicle last moved
  std::optional<plan::Waypoint> planned_at_;  // where the vehicle was at the last plan
};

}  // namespace vog::explore
