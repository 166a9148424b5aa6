#include "vog/explore/exploration_controller.hpp"

#include <cmath>
#include <numbers>
#include <utility>

namespace vog::explore {
namespace {

plan::Waypoint toWaypoint(const geometry::Pose3& T) { return {T.translation(), geometry::yawOf(T.linear())}; }

}  // namespace

const char* toString(Ending ending) {
  switch (ending) {
    case Ending::kNone: return "none";
    case Ending::kComplete: return "complete";
    case Ending::kBudget: return "budget";
    case Ending::kNearHome: return "near_home";
    case Ending::kNoPath: return "no_path";
    case Ending::kStalled: return "stalled";
  }
  return "?";
}

Status ExplorationConfig::validate() const {
  if (max_submaps < 1) return Error{"mission.max_submaps must be >= 1, got " + std::to_string(max_submaps)};
  if (max_idle_plans < 1) return Error{"max_idle_plans must be >= 1, got " + std::to_string(max_idle_plans)};
  if (revisits) return revisit.validate();
  return {};
}

Result<ExplorationController> ExplorationController::create(const ExplorationConfig& config) {
  if (Status st = config.validate(); !st) return st.error();
  return ExplorationController(config);
}

Status ExplorationController::start(const geometry::Pose3& T_world_home, const mission::Box& box, std::int64_t stamp_ns,
                                    bool map_empty) {
  plan::PlannerConfig pc = config_.planner;
  pc.box_min_world_m = box.min_world_m;
  pc.box_max_world_m = box.max_world_m;
  auto planner = plan::NbvPlanner::create(pc, toWaypoint(T_world_home));
  if (!planner) return planner.error();
  std::optional<slam::RevisitPolicy> revisit;
  if (config_.revisits) {
    auto r = slam::RevisitPolicy::create(config_.revisit, stamp_ns);
    if (!r) return r.error();
    revisit = std::move(r).value();
  }
  planner_ = std::move(planner).value();
  revisit_ = std::move(revisit);
  spin_pending_ = map_empty;
  returning_ = false;
  home_path_sent_ = false;
  home_ending_ = Ending::kComplete;
  short_of_home_ = false;
  ending_ = Ending::kNone;
  reason_.clear();
  idle_plans_ = 0;
  planned_at_.reset();
  return {};
}

void ExplorationController::returnHome() {
  if (!active() || returning_) return;
  returning_ = true;
  home_ending_ = Ending::kComplete;
  reason_ = "the operator's return home";
  home_path_sent_ = false;
}

void ExplorationController::hold() { home_path_sent_ = false; }

std::string ExplorationController::summary() const {
  return std::string(toString(ending_)) + (reason_.empty() ? "" : ": " + reason_);
}

std::optional<mission::MissionEvent> ExplorationController::endingEvent() const {
  switch (ending_) {
    case Ending::kNone: return std::nullopt;
    case Ending::kComplete:
    case Ending::kBudget: return mission::MissionEvent::kArrivedHome;
    case Ending::kNearHome: return mission::MissionEvent::kArrivedNearHome;
    case Ending::kNoPath:
    case Ending::kStalled: return mission::MissionEvent::kNoPath;
  }
  return std::nullopt;
}

std::vector<mission::MissionEvent> ExplorationController::eventsFor(mission::MissionState state) const {
  using mission::MissionEvent;
  using mission::MissionState;
  if (state != MissionState::kExploring && state != MissionState::kReturning) return {};
  const std::optional<MissionEvent> ending = endingEvent();
  if (ending == MissionEvent::kNoPath) return {MissionEvent::kNoPath};
  std::vector<MissionEvent> out;
  if (state == MissionState::kExploring && (returning_ || ending)) out.push_back(MissionEvent::kExplorationDone);
  if (ending) out.push_back(*ending);
  return out;
}

void ExplorationController::end(Ending ending, std::string reason, StepOutput& out) {
  ending_ = ending;
  reason_ = std::move(reason);
  out.reason = summary();
  out.event = endingEvent();
  if (out.event == mission::MissionEvent::kNoPath) out.waypoints = std::vector<plan::Waypoint>{};  // hold
}

void ExplorationController::goHome(Ending why, const plan::PlanResult& path, StepOutput& out) {
  if (path.status != plan::PlanStatus::kComplete && path.status != plan::PlanStatus::kNearHome) {
    end(Ending::kNoPath, path.reason, out);
    return;
  }
  if (!returning_) {
    returning_ = true;
    home_ending_ = why;
    reason_ = path.reason;
    out.event = mission::MissionEvent::kExplorationDone;
    out.reason = reason_;
  }
  // Each new way home says again whether it reaches home (the map may have opened the way since).
  short_of_home_ = path.status == plan::PlanStatus::kNearHome;
  if (short_of_home_) reason_ = path.reason;
  out.waypoints = path.waypoints;
  home_path_sent_ = true;
}

Result<StepOutput> ExplorationController::step(const StepInput& input) {
  StepOutput out;
  if (!active()) return out;
  const plan::Waypoint now = toWaypoint(input.T_world_vehicle);
  bool idle = input.vehicle_idle;
  if (input.obstruction) {
    // The vehicle holds where it was stopped; the planner backs it off the way it came.
    planner_->reportObstruction(input.obstruction->p_world, input.obstruction->target_world);
    out.waypoints = std::vector<plan::Waypoint>{};
    idle = true;
    home_path_sent_ = false;  // on the way home: plan it again from here
  }
  if (!idle) {
    idle_plans_ = 0;
    return out;
  }
  if (std::exchange(spin_pending_, false)) {
    std::vector<plan::Waypoint> spin;
    for (int k = 1; k <= 4; ++k)
      spin.push_back({now.p_world, geometry::wrapAngle(now.yaw_rad + k * std::numbers::pi / 2)});
    out.waypoints = std::move(spin);
    return out;
  }
  if (returning_ && home_path_sent_) {
    end(short_of_home_ ? Ending::kNearHome : home_ending_, reason_, out);
    return out;
  }
  auto snapshot = input.map ? input.map() : Result<std::shared_ptr<const map::MergedMap>>(nullptr);
  if (!snapshot) return snapshot.error();
  if (!*snapshot) return out;  // nothing merged yet: the next step tries again
  const bool budget_spent = !returning_ && input.n_submaps >= static_cast<std::size_t>(config_.max_submaps);
  if (returning_ || budget_spent) {
    auto home = planner_->planHome(*snapshot, now);
    if (!home) return home.error();
    if (budget_spent)
      home->reason = "submap budget of " + std::to_string(config_.max_submaps) + " reached" +
                     (home->status == plan::PlanStatus::kComplete ? "" : "; " + home->reason);
    else if (home->status == plan::PlanStatus::kNoPath)
      home->reason = "no way home: " + home->reason;
    out.plan = *home;
    goHome(budget_spent ? Ending::kBudget : home_ending_, *home, out);
    return out;
  }
  if (revisit_ && input.submaps != nullptr && input.closures != nullptr) {
    std::vector<plan::Waypoint> views;
    for (const geometry::Pose3& T : revisit_->due(*input.submaps, *input.closures, now.p_world, input.stamp_ns))
      views.push_back(toWaypoint(T));
    if (!views.empty()) planner_->requestRevisit(std::move(views));
  }
  auto result = planner_->plan(*snapshot, now);
  if (!result) return result.error();
  out.plan = *result;
  switch (result->status) {
    case plan::PlanStatus::kNoPath: end(Ending::kNoPath, result->reason, out); return out;
    case plan::PlanStatus::kComplete:  // nothing left to explore: the plan is the way home
    case plan::PlanStatus::kNearHome: goHome(Ending::kComplete, *result, out); return out;
    case plan::PlanStatus::kExplore: break;
  }
  // A vehicle seen idle at every step may still have moved in between (a caller that polls slower than
  // the vehicle reaches its waypoints): only plans from where the last one was made count.
  constexpr double kMovedM = 0.05, kTurnedRad = 0.02;
  const bool moved = planned_at_ && ((now.p_world - planned_at_->p_world).norm() > kMovedM ||
                                     std::abs(geometry::wrapAngle(now.yaw_rad - planned_at_->yaw_rad)) > kTurnedRad);
  if (moved) idle_plans_ = 0;
  planned_at_ = now;
  if (result->waypoints.empty() || ++idle_plans_ > config_.max_idle_plans) {
    end(Ending::kStalled,
        "the planner answered " + std::to_string(idle_plans_) + " times without moving the vehicle" +
            (result->waypoints.empty() ? ", the last time with no waypoint" : "") +
            (result->reason.empty() ? "" : ": " + result->reason),
        out);
    return out;
  }
  out.waypoints = result->waypoints;
  return out;
}

}  // namespace vog::explore
