#pragma once
// A test double of vogd behind the API: a real MergedMap built from LocalGrids of the synthetic pier,
// a real mission state machine (the mission lifecycle), a reconstruction cloud, and a logger that
// records what the server reports.

#include "map_fixtures.hpp"
#include "vog/api/domain.hpp"

#include <algorithm>
#include <mutex>
#include <string>
#include <vector>

namespace vog::api::test {

class FakeBackend final : public ApiBackend {
 private:
  // The graph of the merged submaps at their poses, the next version (caller holds mutex_).
  void publishGraphLocked() {
    auto g = std::make_shared<GraphState>();
    g->version = graph_ ? graph_->version + 1 : 1;
    std::vector<std::size_t> ids = merged_ids_;
    std::sort(ids.begin(), ids.end());
    for (const std::size_t i : ids) g->submaps.push_back({entries_[i].id, entries_[i].T_world_submap});
    g->closures = closures_;
    graph_ = std::move(g);
  }

 public:
  // `n_initial` of the built submaps are merged at construction; addSubmap() merges more.
  explicit FakeBackend(int n_submaps = 6, std::size_t n_initial = 3) {
    const auto built = map::test_fixtures::buildSubmaps(config_, n_submaps, 15, 7, 4.0);
    for (std::size_t i = 0; i < built.size(); ++i) {
      entries_.push_back(
          {static_cast<map::SubmapId>(i), built[i].grid, built[i].T_world_submap, built[i].T_world_submap.inverse()});
    }
    merged_ = map::MergedMap::create(config_).value();
    for (std::size_t i = 0; i < n_initial && i < entries_.size(); ++i) addSubmap(i);
    for (int i = 0; i < 1000; ++i) {
      const float a = static_cast<float>(i) * 0.01f;
      cloud_->points.push_back({Eigen::Vector3f(std::cos(a), std::sin(a), -0.001f * static_cast<float>(i)),
                                Eigen::Vector3f(std::cos(a), std::sin(a), 0.0f)});
    }
  }

  // Merges submap i (the merge thread's job in vogd) and publishes a new snapshot.
  void addSubmap(std::size_t i) {
    std::lock_guard lock(mutex_);
    (void)merged_->add(entries_.at(i));
    merged_ids_.push_back(i);
    snapshot_ = merged_->snapshot();
    publishGraphLocked();
  }
  // Moves a merged submap (a loop closure) and re-merges it.
  void moveSubmap(std::size_t i, const geometry::Pose3& T_delta) {
    std::lock_guard lock(mutex_);
    (void)merged_->remove(static_cast<map::SubmapId>(i));
    entries_[i].T_world_submap = T_delta * entries_[i].T_world_submap;
    entries_[i].T_submap_world = entries_[i].T_world_submap.inverse();
    (void)merged_->add(entries_[i]);
    snapshot_ = merged_->snapshot();
    publishGraphLocked();
  }
  // A loop closure between two merged submaps (in the graph from the next change on).
  void addClosure(std::uint32_t from, std::uint32_t to) {
    std::lock_guard lock(mutex_);
    closures_.push_back({from, to});
    publishGraphLocked();
  }

  std::shared_ptr<const GraphState> graph() const override {
    std::lock_guard lock(mutex_);
    return graph_;
  }
  std::shared_ptr<const map::LocalGrid> submapGrid(std::uint32_t id) const override {
    std::lock_guard lock(mutex_);
    for (const std::size_t i : merged_ids_) {
      if (entries_[i].id == id) return entries_[i].grid;
    }
    return nullptr;
  }
  // The merged submaps as vogd's merge holds them (for comparisons with a client's copy).
  std::vector<map::SubmapEntry> mergedEntries() const {
    std::lock_guard lock(mutex_);
    std::vector<map::SubmapEntry> out;
    for (const std::size_t i : merged_ids_) out.push_back(entries_[i]);
    return out;
  }

  std::shared_ptr<const map::MergedMap> mapSnapshot() const override {
    std::lock_guard lock(mutex_);
    return snapshot_;
  }

  StatusReport status() const override {
    std::lock_guard lock(mutex_);
    StatusReport s;
    s.stamp_ns = 123'456'789'000;
    s.mission_state = state_;
    s.T_world_vehicle = geometry::poseFromXyzRpy(1.5, -2.0, -3.25, 0.01, -0.02, 0.7);
    s.sigma_xyz_m = {0.1, 0.2, 0.05};
    s.sigma_yaw_rad = 0.003;
    s.devices = {{"dvl", DeviceState::kOk, "", 123'000'000'000, 1200, 0},
                 {"sonar", DeviceState::kDegraded, "3 frames late", 122'900'000'000, 600, 3}};
    s.n_submaps = static_cast<std::uint32_t>(merged_ids_.size());
    s.n_closures = 1;
    s.planner_state = PlannerState::kFollowing;
    s.map_version = snapshot_ ? snapshot_->version() : 0;
    return s;
  }

  std::vector<SubmapInfo> submaps() const override {
    std::lock_guard lock(mutex_);
    std::vector<SubmapInfo> out;
    for (const std::size_t i : merged_ids_) {
      const auto& e = entries_[i];
      out.push_back({static_cast<std::uint32_t>(e.id), e.T_world_submap,
                     static_cast<std::uint32_t>(e.grid->scanCount()), static_cast<std::int64_t>(i) * 1'000'000'000,
                     static_cast<std::int64_t>(i) * 1'000'000'000 + 999, true});
    }
    return out;
  }

  std::shared_ptr<const ServedCloud> cloud() const override { return cloud_; }

  // The mission lifecycle; refusals name the state.
  Result<MissionState> command(const MissionCommand& c) override {
    std::lock_guard lock(mutex_);
    using K = MissionCommand::Kind;
    const auto refuse = [&](const char* what) -> Result<MissionState> {
      return Error{std::string(what) + " while " + toString(state_)};
    };
    switch (c.kind) {
      case K::kSetBox:
        if (state_ != MissionState::kIdle) return refuse("set-box");
        box_ = c.box;
        has_box_ = true;
        break;
      case K::kStart:
        if (state_ != MissionState::kIdle || !has_box_) return refuse("start");
        state_ = MissionState::kExploring;
        break;
      case K::kPause:
        if (state_ != MissionState::kExploring && state_ != MissionState::kReturning) return refuse("pause");
        paused_from_ = state_;
        state_ = MissionState::kPaused;
        break;
      case K::kResume:
        if (state_ != MissionState::kPaused) return refuse("resume");
        state_ = paused_from_;
        break;
      case K::kAbort: state_ = MissionState::kAborted; break;
      case K::kReturnHome:
        if (state_ != MissionState::kExploring && state_ != MissionState::kPaused) return refuse("return-home");
        state_ = MissionState::kReturning;
        break;
    }
    commands_.push_back(c);
    return state_;
  }

  std::string configText() const override { return "api:\n  port: 7400\nmap:\n  resolution_m: 0.095\n"; }

  const map::GridConfig& gridConfig() const { return config_; }

  std::vector<MissionCommand> commands() const {
    std::lock_guard lock(mutex_);
    return commands_;
  }
  ExplorationBox box() const {
    std::lock_guard lock(mutex_);
    return box_;
  }
  const Cloud& cloudData() const { return cloud_->points; }

 private:
  map::GridConfig config_;
  mutable std::mutex mutex_;
  std::vector<map::SubmapEntry> entries_;                // guarded by mutex_
  std::unique_ptr<map::MergedMap> merged_;               // guarded by mutex_
  std::shared_ptr<const map::MergedMap> snapshot_;       // guarded by mutex_
  std::vector<std::size_t> merged_ids_;                  // guarded by mutex_
  MissionState state_ = MissionState::kIdle;             // guarded by mutex_
  MissionState paused_from_ = MissionState::kExploring;  // guarded by mutex_
  ExplorationBox box_;                                   // guarded by mutex_
  bool has_box_ = false;                                 // guarded by mutex_
  std::vector<MissionCommand> commands_;                 // guarded by mutex_
  std::vector<ClosurePair> closures_;                    // guarded by mutex_
  std::shared_ptr<const GraphState> graph_;              // guarded by mutex_
  std::shared_ptr<ServedCloud> cloud_ = std::make_shared<ServedCloud>();
};

// Records every log line (the server logs from its io thread).
class RecordingLogger final : public ApiLogger {
 public:
  void log(LogLevel level, std::string_view message) override {
    std::lock_guard lock(mutex_);
    lines_.push_back({level, std::string(message)});
  }
  bool contains(LogLevel level, std::string_view text) const {
    std::lock_guard lock(mutex_);
    for (const auto& [l, m] : lines_) {
      if (l == level && m.find(text) != std::string::npos) return true;
    }
    return false;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::pair<LogLevel, std::string>> lines_;  // guarded by mutex_
};

}  // namespace vog::api::test
