#include "vog/mission/mission_control.hpp"

namespace vog::mission {

const char* toString(MissionCommandKind kind) {
  switch (kind) {
    case MissionCommandKind::kSetBox: return "set box";
    case MissionCommandKind::kStart: return "start";
    case MissionCommandKind::kPause: return "pause";
    case MissionCommandKind::kResume: return "resume";
    case MissionCommandKind::kAbort: return "abort";
    case MissionCommandKind::kReturnHome: return "return home";
  }
  return "?";
}

const char* toString(MissionEvent event) {
  switch (event) {
    case MissionEvent::kExplorationDone: return "exploration done";
    case MissionEvent::kArrivedHome: return "arrived home";
    case MissionEvent::kArrivedNearHome: return "arrived near home";
    case MissionEvent::kNoPath: return "no path";
  }
  return "?";
}

MissionControl::MissionControl(std::optional<Box> box, MissionState state) : box_(std::move(box)), state_(state) {
  if (state_ == MissionState::kPaused) paused_from_ = MissionState::kExploring;
}

Result<MissionState> MissionControl::command(MissionCommandKind kind, const std::optional<Box>& box) {
  auto refuse = [&](const char* why) -> Result<MissionState> {
    return Error{std::string(toString(kind)) + " refused while " + toString(state_) + (why[0] ? ": " : "") + why};
  };
  switch (kind) {
    case MissionCommandKind::kSetBox:
      if (!box) return Error{"set box without a box"};
      // The running exploration keeps the box it started with: a new box is for the next start.
      if (active() || state_ == MissionState::kPaused)
        return refuse("abort first, or set it once the mission has ended");
      box_ = box;
      return state_;
    case MissionCommandKind::kStart:
      if (state_ != MissionState::kIdle && !ended()) return refuse("");
      if (!box_) return refuse("no exploration box is set");
      state_ = MissionState::kExploring;
      reason_.clear();
      return state_;
    case MissionCommandKind::kPause:
      if (!active()) return refuse("");
      paused_from_ = state_;
      state_ = MissionState::kPaused;
      return state_;
    case MissionCommandKind::kResume:
      if (state_ != MissionState::kPaused) return refuse("");
      state_ = paused_from_;
      return state_;
    case MissionCommandKind::kAbort:
      if (ended()) return refuse("");
      state_ = MissionState::kAborted;
      reason_ = "aborted by the operator";
      return state_;
    case MissionCommandKind::kReturnHome:
      if (state_ != MissionState::kExploring && state_ != MissionState::kPaused) return refuse("");
      state_ = MissionState::kReturning;
      return state_;
  }
  return refuse("unknown command");
}

MissionState MissionControl::event(MissionEvent e) {
  switch (e) {
    case MissionEvent::kExplorationDone:
      if (state_ == MissionState::kExploring) state_ = MissionState::kReturning;
      break;
    case MissionEvent::kArrivedHome:
      if (state_ == MissionState::kReturning) state_ = MissionState::kComplete;
      break;
    case MissionEvent::kArrivedNearHome:
      if (state_ == MissionState::kReturning) state_ = MissionState::kNearHome;
      break;
    case MissionEvent::kNoPath:
      if (active()) {
        state_ = MissionState::kAborted;
        if (reason_.empty()) reason_ = "no collision-free path";
      }
      break;
  }
  return state_;
}

}  // namespace vog::mission
