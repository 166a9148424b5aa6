#include "vog/mission/mission_store.hpp"

#include <map>
#include <string>

namespace vog::mission {
namespace {

std::string at(std::uint64_t offset) { return "journal record at byte offset " + std::to_string(offset); }

SubmapClosedRecord toRecord(const slam::ClosedSubmap& c, const StoredSubmapFile& file) {
  SubmapClosedRecord r;
  r.index = c.index;
  r.first_stamp_ns = c.first_stamp_ns;
  r.last_stamp_ns = c.last_stamp_ns;
  r.n_scans = c.n_scans;
  r.reason = c.reason;
  r.T_world_base_odom = c.T_world_base_odom;
  r.base_z_roll_pitch = c.base_z_roll_pitch;
  r.has_previous = c.has_previous;
  r.odometry_from_previous = c.odometry_from_previous;
  r.odometry_covariance = c.odometry_covariance;
  r.ot_file = file.file_name;
  r.ot_size_bytes = file.size_bytes;
  r.ot_crc32c = file.crc32c;
  r.sensor_origins = c.grid->sensorOrigins();
  return r;
}

slam::ClosedSubmap fromRecord(const SubmapClosedRecord& r, std::shared_ptr<const map::LocalGrid> grid) {
  slam::ClosedSubmap c;
  c.index = r.index;
  c.grid = std::move(grid);
  c.T_world_base_odom = r.T_world_base_odom;
  c.base_z_roll_pitch = r.base_z_roll_pitch;
  c.first_stamp_ns = r.first_stamp_ns;
  c.last_stamp_ns = r.last_stamp_ns;
  c.n_scans = static_cast<std::size_t>(r.n_scans);
  c.reason = r.reason;
  c.has_previous = r.has_previous;
  c.odometry_from_previous = r.odometry_from_previous;
  c.odometry_covariance = r.odometry_covariance;
  return c;
}

// The journal replayed into committed state. `uncommitted_offset` is where a trailing unfinished group
// starts (the file is cut there).
struct Replay {
  std::vector<SubmapClosedRecord> submaps;
  std::vector<LoopClosureRecord> closures;
  std::map<slam::NodeId, slam::Vector6d> estimates;
  std::optional<MissionStateRecord> state;
  std::optional<WaypointRecord> waypoint;
  std::optional<std::uint64_t> uncommitted_offset;
  std::size_t uncommitted_records = 0;
};

Result<Replay> replay(const JournalContents& journal) {
  Replay out;
  std::optional<SubmapClosedRecord> open_submap;
  std::uint64_t open_offset = 0;
  std::vector<LoopClosureRecord> open_closures;
  std::size_t open_records = 0;
  for (const JournalEntry& e : journal.entries) {
    if (const auto* s = std::get_if<SubmapClosedRecord>(&e.record)) {
      if (open_submap) {
        return Error{at(e.offset) + ": submap " + std::to_string(s->index) + " closed while the group of submap " +
                     std::to_string(open_submap->index) + " (byte offset " + std::to_string(open_offset) +
                     ") has no optimized-poses commit"};
      }
      const auto expected = static_cast<std::int64_t>(out.submaps.size());
      if (s->index != expected) {
        return Error{at(e.offset) + ": submap index " + std::to_string(s->index) + ", expected " +
                     std::to_string(expected)};
      }
      open_submap = *s;
      open_offset = e.offset;
      open_records = 1;
    } else if (const auto* c = std::get_if<LoopClosureRecord>(&e.record)) {
      if (!open_submap || c->to != open_submap->index || c->from < 0 || c->from >= c->to) {
        return Error{at(e.offset) + ": loop closure " + std::to_string(c->from) + " -> " + std::to_string(c->to) +
                     " outside the group of its newer submap"};
      }
      open_closures.push_back(*c);
      ++open_records;
    } else if (const auto* o = std::get_if<OptimizedPosesRecord>(&e.record)) {
      const std::int64_t n_nodes = static_cast<std::int64_t>(out.submaps.size()) + (open_submap ? 1 : 0);
      for (const auto& [id, x] : o->estimates) {
        if (id < 0 || id >= n_nodes) {
          return Error{at(e.offset) + ": estimate of unknown node " + std::to_string(id) + " (" +
                       std::to_string(n_nodes) + " submaps)"};
        }
      }
      for (const auto& [id, x] : o->estimates) out.estimates[id] = x;
      if (open_submap) {
        if (out.estimates.count(open_submap->index) == 0) {
          return Error{at(e.offset) + ": commit of submap " + std::to_string(open_submap->index) +
                       " lacks its estimate"};
        }
        out.submaps.push_back(*open_submap);
        for (auto& lc : open_closures) out.closures.push_back(std::move(lc));
        open_submap.reset();
        open_closures.clear();
        open_records = 0;
      }
    } else if (open_submap) {
      return Error{at(e.offset) + ": waypoint or state record inside the group of submap " +
                   std::to_string(open_submap->index)};
    } else if (const auto* w = std::get_if<WaypointRecord>(&e.record)) {
      out.waypoint = *w;
    } else if (const auto* m = std::get_if<MissionStateRecord>(&e.record)) {
      out.state = *m;
    }
  }
  if (open_submap) {
    out.uncommitted_offset = open_offset;
    out.uncommitted_records = open_records;
  }
  return out;
}

}  // namespace

Result<std::unique_ptr<MissionStore>> MissionStore::open(const std::filesystem::path& dir, const map::GridConfig& grid,
                                                         MissionResume* resume) {
  if (Status s = grid.validate(); !s.ok()) return Error{"mission store: " + s.error().message};
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec)) {
    return Error{"mission store: " + dir.string() + " exists and is not a directory"};
  }
  const bool created = std::filesystem::create_directories(dir, ec);
  if (ec) return Error{"mission store: cannot create mission directory " + dir.string() + ": " + ec.message()};
  if (created) {
    const std::filesystem::path parent = dir.has_parent_path() ? dir.parent_path() : std::filesystem::path(".");
    if (Status s = syncDirectory(parent); !s.ok()) return Error{"mission store: " + s.error().message};
  }
  auto submaps = SubmapStore::open(dir);
  if (!submaps) return Error{"mission store: " + submaps.error().message};
  JournalContents contents;
  auto journal = Journal::open(dir / kJournalFile, &contents);
  if (!journal) return Error{"mission store: " + journal.error().message};
  auto state = replay(contents);
  if (!state) return Error{"mission store: " + (dir / kJournalFile).string() + ": " + state.error().message};

  MissionResume out;
  out.journal_tail = contents.tail;
  out.uncommitted_records = state->uncommitted_records;
  out.journal_records = contents.entries.size() - state->uncommitted_records;
  out.state = state->state;
  out.waypoint = state->waypoint;
  for (const SubmapClosedRecord& r : state->submaps) {
    auto g = submaps->read(grid, {r.ot_file, r.ot_size_bytes, r.ot_crc32c}, r.sensor_origins);
    if (!g) return Error{"mission store: submap " + std::to_string(r.index) + ": " + g.error().message};
    out.pipeline.submaps.push_back(fromRecord(r, std::move(g.value())));
    out.pipeline.estimates.push_back(state->estimates.at(r.index));
  }
  for (const LoopClosureRecord& r : state->closures) {
    slam::LoopClosure lc;
    lc.from = r.from;
    lc.to = r.to;
    lc.T_from_to = r.T_from_to;
    lc.T_from_to_prior = r.T_from_to_prior;
    lc.factor = r.factor;
    out.pipeline.closures.push_back(std::move(lc));
  }
  // Cut an unfinished group only now that everything else read cleanly: an error above changes nothing.
  if (state->uncommitted_offset) {
    if (Status s = journal.value()->truncate(*state->uncommitted_offset); !s.ok()) {
      return Error{"mission store: " + s.error().message};
    }
  }
  const auto next_index = static_cast<std::int64_t>(state->submaps.size());
  if (resume != nullptr) *resume = std::move(out);
  return std::unique_ptr<MissionStore>(
      new MissionStore(dir, std::move(submaps.value()), std::move(journal.value()), next_index));
}

std::int64_t MissionStore::nextSubmapIndex() const {
  std::lock_guard lock(mutex_);
  return next_index_;
}

void MissionStore::queueLocked(PendingWrite write) {
  const bool waypoint = write.records.size() == 1 && std::holds_alternative<WaypointRecord>(write.records.front());
  if (waypoint && !pending_.empty() && pending_.back().records.size() == 1 &&
      std::holds_alternative<WaypointRecord>(pending_.back().records.front())) {
    pending_.back() = std::move(write);  // only the newest waypoint matters on resume
  } else {
    pending_.push_back(std::move(write));
  }
  flushLocked();
}

void MissionStore::flushLocked() {
  if (journal_failed_) {
    if (Status s = journal_->rollback(written_bytes_); !s.ok()) {
      fault_ = s.error();
      return;
    }
    journal_failed_ = false;
  }
  while (!pending_.empty()) {
    PendingWrite& w = pending_.front();
    if (w.grid) {
      auto& record = std::get<SubmapClosedRecord>(w.records.front());
      auto file = submaps_.write(record.index, *w.grid);
      if (!file) {
        fault_ = file.error();
        return;
      }
      record.ot_file = file->file_name;
      record.ot_size_bytes = file->size_bytes;
      record.ot_crc32c = file->crc32c;
      w.grid.reset();
    }
    Status s = Status::success();
    for (std::size_t i = 0; i < w.records.size() && s.ok(); ++i) s = journal_->append(w.records[i]);
    if (s.ok() && w.sync) s = journal_->sync();
    if (!s.ok()) {
      // Nothing of this item stays in the journal: the next attempt rolls back to written_bytes_.
      journal_failed_ = true;
      fault_ = Error{"mission store: journal: " + s.error().message};
      return;
    }
    written_bytes_ = journal_->sizeBytes();
    pending_.pop_front();
  }
  fault_.reset();
}

StorageHealth MissionStore::healthLocked() const {
  StorageHealth h;
  if (!pending_.empty() || journal_failed_) h.fault = fault_;
  for (const PendingWrite& w : pending_) {
    const bool submap = std::holds_alternative<SubmapClosedRecord>(w.records.front());
    (submap ? h.pending_submaps : h.pending_records) += 1;
  }
  return h;
}

StorageHealth MissionStore::retryPending() {
  std::lock_guard lock(mutex_);
  flushLocked();
  return healthLocked();
}

StorageHealth MissionStore::health() const {
  std::lock_guard lock(mutex_);
  return healthLocked();
}

Status MissionStore::onSubmapClosed(const slam::ClosedSubmap& closed) {
  std::lock_guard lock(mutex_);
  if (!staged_.empty()) {
    return Error{"mission store: submap " + std::to_string(closed.index) +
                 " closed before the previous one was committed"};
  }
  if (closed.index != next_index_) {
    return Error{"mission store: submap index " + std::to_string(closed.index) + ", expected " +
                 std::to_string(next_index_)};
  }
  if (!closed.grid || !closed.grid->finalized()) {
    return Error{"mission store: submap " + std::to_string(closed.index) + " has no finalized grid"};
  }
  staged_.push_back(toRecord(closed, StoredSubmapFile{SubmapStore::fileName(closed.index), 0, 0}));
  staged_grid_ = closed.grid;
  return Status::success();
}

Status MissionStore::onClosures(const std::vector<slam::LoopClosure>& closures) {
  std::lock_guard lock(mutex_);
  if (staged_.empty() && !closures.empty()) return Error{"mission store: loop closures outside a submap group"};
  for (const slam::LoopClosure& lc : closures) {
    if (lc.to != next_index_ || lc.from < 0 || lc.from >= lc.to) {
      return Error{"mission store: loop closure " + std::to_string(lc.from) + " -> " + std::to_string(lc.to) +
                   " does not end at the new submap " + std::to_string(next_index_)};
    }
  }
  for (const slam::LoopClosure& lc : closures) {
    staged_.push_back(LoopClosureRecord{lc.from, lc.to, lc.T_from_to, lc.T_from_to_prior, lc.factor});
  }
  return Status::success();
}

Status MissionStore::onOptimized(const std::vector<std::pair<slam::NodeId, slam::Vector6d>>& estimates) {
  std::lock_guard lock(mutex_);
  const std::int64_t n_nodes = next_index_ + (staged_.empty() ? 0 : 1);
  for (const auto& [id, x] : estimates) {
    if (id < 0 || id >= n_nodes || !x.allFinite()) {
      staged_.clear();
      staged_grid_.reset();
      return Error{"mission store: estimate of node " + std::to_string(id) + " is unknown or not finite"};
    }
  }
  staged_.push_back(OptimizedPosesRecord{estimates});
  if (std::holds_alternative<SubmapClosedRecord>(staged_.front())) ++next_index_;
  queueLocked(PendingWrite{std::move(staged_grid_), std::move(staged_), true});
  staged_.clear();
  staged_grid_.reset();
  return Status::success();
}

Status MissionStore::onUpdate(const slam::MappingPipeline& pipeline, const slam::MappingUpdate& update) {
  if (!update.closed) return Status::success();
  if (Status s = onSubmapClosed(*update.closed); !s.ok()) return s;
  if (Status s = onClosures(update.closures); !s.ok()) return s;
  std::vector<slam::NodeId> ids;
  if (update.optimized) {
    ids = pipeline.graph().nodeIds();
  } else {
    ids.push_back(update.closed->index);
  }
  std::vector<std::pair<slam::NodeId, slam::Vector6d>> estimates;
  for (slam::NodeId id : ids) {
    auto x = pipeline.graph().estimate(id);
    if (!x) return Error{"mission store: " + x.error().message};
    estimates.emplace_back(id, x.value());
  }
  return onOptimized(estimates);
}

Status MissionStore::onWaypoint(const WaypointRecord& waypoint) {
  std::lock_guard lock(mutex_);
  if (!Eigen::Vector4d(waypoint.x_m, waypoint.y_m, waypoint.z_m, waypoint.yaw_rad).allFinite()) {
    return Error{"mission store: waypoint at stamp_ns " + std::to_string(waypoint.stamp_ns) + " is not finite"};
  }
  queueLocked(PendingWrite{nullptr, {waypoint}, false});
  return Status::success();
}

Status MissionStore::onState(const MissionStateRecord& state) {
  std::lock_guard lock(mutex_);
  queueLocked(PendingWrite{nullptr, {state}, true});
  return Status::success();
}

Status MissionStore::sync() {
  std::lock_guard lock(mutex_);
  flushLocked();
  if (!pending_.empty() || journal_failed_) return *fault_;
  if (Status s = journal_->sync(); !s.ok()) {
    journal_failed_ = true;
    fault_ = Error{"mission store: journal: " + s.error().message};
    return *fault_;
  }
  return Status::success();
}

}  // namespace vog::mission
