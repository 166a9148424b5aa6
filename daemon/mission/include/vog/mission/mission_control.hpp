#pragma once
// MissionControl: the mission lifecycle of vogd as a pure state machine.
//
//   idle --start--> exploring --planner done--> returning --arrived home--> complete
//   returning --arrived near home--> near_home         (home was not reachable through known free
//                                                       space: the vehicle waits at the reachable
//                                                       safe position nearest to it)
//   exploring|returning --pause--> paused --resume--> (the state it was paused in)
//   exploring|paused --return home--> returning
//   any but an end --abort--> aborted                  (the vehicle holds where it is)
//   an end (complete|near_home|aborted) --start--> exploring   (a new exploration on the same map)
//   exploring|returning --no path--> aborted            (the planner found no collision-free way on)
//
// The exploration box may be replaced while no exploration holds it (idle, or after an end: the box of
// the next start); exploring needs a box. Every refused transition returns an error that names the command
// and the state. Lifecycle: construct (optionally resumed from a journaled state: exploring and
// returning resume as they were, paused resumes paused); no threads (the caller serialises).

#include "vog/core/result.hpp"
#include "vog/mission/journal.hpp"

#include <Eigen/Core>

#include <optional>
#include <string>

namespace vog::mission {

struct Box {
  Eigen::Vector3d min_world_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_world_m = Eigen::Vector3d::Zero();
  bool contains(const Eigen::Vector3d& p) const {
    return (p.array() >= min_world_m.array()).all() && (p.array() <= max_world_m.array()).all();
  }
};

enum class MissionCommandKind { kSetBox, kStart, kPause, kResume, kAbort, kReturnHome };
const char* toString(MissionCommandKind kind);

// What the planner reported to the mission.
enum class MissionEvent { kExplorationDone, kArrivedHome, kArrivedNearHome, kNoPath };
const char* toString(MissionEvent event);

class MissionControl {
 public:
  explicit MissionControl(std::optional<Box> box = std::nullopt, MissionState state = MissionState::kIdle);

  // An operator's command; `box` is used by kSetBox only (validated by the caller). The new state, or
  // an error naming why it was refused.
  Result<MissionState> command(MissionCommandKind kind, const std::optional<Box>& box = std::nullopt);
  // A planner event; events that do not apply to the current state are ignored (they can race with a
  // pause or an abort) and leave the state unchanged.
  MissionState event(MissionEvent e);

  MissionState state() const { return state_; }
  const std::optional<Box>& box() const { return box_; }
  // The vehicle should be moving under the planner: exploring or returning.
  bool active() const { return state_ == MissionState::kExploring || state_ == MissionState::kReturning; }
  // The mission has ended (complete, near_home or aborted).
  bool ended() const {
    return state_ == MissionState::kComplete || state_ == MissionState::kNearHome || state_ == MissionState::kAborted;
  }
  // Why the mission was last aborted (empty otherwise).
  const std::string& reason() const { return reason_; }
  void setAbortReason(std::string reason) { reason_ = std::move(reason); }

 private:
  std::optional<Box> box_;
  MissionState state_;
  MissionState paused_from_ = MissionState::kExploring;
  std::string reason_;
};

}  // namespace vog::mission
