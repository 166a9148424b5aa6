#include "vog/app/mapping_stage.hpp"

#include "vog/api/graph.hpp"
#include "vog/app/scan_record.hpp"

#include <spdlog/spdlog.h>

#include <string>
#include <vector>
#include <utility>

namespace vog::app {

MappingStage::MappingStage(bool record_scans, std::unique_ptr<slam::MappingPipeline> pipeline,
                           mission::MissionStore& store, RawRecorder& raw, map::MergeWorker& merge,
                           std::function<void()> published)
    : record_scans_(record_scans),
      pipeline_(std::move(pipeline)),
      store_(store),
      raw_(raw),
      merge_(merge),
      published_(std::move(published)) {
  if (!pipeline_->submaps().empty()) merge_.submit(pipeline_->map().entries());
  publish();
}

Result<bool> MappingStage::process(const QueuedScan& item, bool mapping_enabled) {
  const slam::ScanInput& scan = item.scan;
  if (record_scans_) {
    // The simulator's "device" output is the scan itself (scan_record.hpp), with its true pose.
    const bool mapped = raw_.gate(mapping_enabled, scan.scan.stamp_ns);
    raw_.record(kSimScanDeviceId, scan.scan.stamp_ns, encodeScanRecord(scan));
    if (item.T_world_vehicle_true)
      raw_.record(kSimTruthDeviceId, scan.scan.stamp_ns,
                  encodeTruthRecord({scan.scan.stamp_ns, *item.T_world_vehicle_true}));
    if (!mapped) return false;
  }
  auto update = pipeline_->feed(scan);
  if (!update) {
    if (rejected_scans_++ < 10)
      spdlog::warn("mapping: scan at {} ns rejected: {}", scan.scan.stamp_ns, update.error().message);
  } else if (update->closed_submap || !update->moved.empty()) {
    if (auto st = persist(*update); !st) return st.error();
  }
  return true;
}

void MappingStage::finish(bool store_active) {
  if (store_active) {
    auto update = pipeline_->finish();
    if (!update) {
      spdlog::warn("mapping: closing the active submap at shutdown: {}", update.error().message);
    } else if (update->closed_submap) {
      if (auto st = persist(*update); !st) spdlog::error("mission store at shutdown: {}", st.error().message);
    }
  }
  const mission::StorageHealth left = store_.retryPending();
  if (left.pending_submaps > 0)
    spdlog::error("mission store at shutdown: {} closed submaps could not be stored: {}", left.pending_submaps,
                  left.fault ? left.fault->message : std::string("unknown error"));
  raw_.sync();
}

void MappingStage::retryStorage() {
  const auto now = std::chrono::steady_clock::now();
  if (now - last_retry_ < std::chrono::seconds(1)) return;
  last_retry_ = now;
  if (!store_.health().fault) return;
  logStorage(store_.retryPending());
}

void MappingStage::logStorage(const mission::StorageHealth& health) {
  if (health.fault && !storage_fault_logged_) {
    spdlog::error("mission store: {} ({} submaps pending; mapping goes on, retrying)", health.fault->message,
                  health.pending_submaps);
    storage_fault_logged_ = true;
  } else if (!health.fault && storage_fault_logged_) {
    spdlog::info("mission store: the pending submaps are stored");
    storage_fault_logged_ = false;
  }
}

api::DeviceHealth MappingStage::storageHealth() const {
  const mission::StorageHealth store = store_.health();
  const RawRecorder::Health raw = raw_.health();
  api::DeviceHealth h;
  h.name = "storage";
  std::vector<std::string> notes;
  if (store.fault) {
    h.state = api::DeviceState::kDegraded;
    notes.push_back(store.fault->message + " (" + std::to_string(store.pending_submaps) + " submaps pending)");
  }
  if (raw.fault) {
    h.state = api::DeviceState::kDegraded;
    notes.push_back("raw log stopped: " + *raw.fault);
  }
  if (raw.dropped_segments > 0)
    notes.push_back("raw log: " + std::to_string(raw.dropped_segments) + " oldest segments (" +
                    std::to_string(raw.dropped_bytes) + " bytes) dropped to stay within mission.raw_log_max_bytes");
  if (!raw.recording) notes.push_back("raw log: recording stopped (the mission ended)");
  for (const std::string& n : notes) h.detail += (h.detail.empty() ? "" : "; ") + n;
  h.errors = store.pending_submaps;
  return h;
}

std::shared_ptr<const MappingState> MappingStage::state() const {
  const std::lock_guard lock(mutex_);
  return state_;
}

Status MappingStage::persist(const slam::MappingUpdate& update) {
  // Durable first (the journal group is the commit), then visible to the merge and the API.
  if (update.closed_submap) {
    if (auto st = store_.onUpdate(*pipeline_, update); !st) return st;
    logStorage(store_.health());
    raw_.sync();
    spdlog::info("submap {} closed ({} scans){}", *update.closed_submap, pipeline_->submaps().back().n_scans,
                 update.closures.empty() ? "" : ", " + std::to_string(update.closures.size()) + " loop closures");
  }
  merge_.submit(pipeline_->map().entries());
  publish();
  return {};
}

std::shared_ptr<const api::GraphState> MappingStage::graphOf(const MappingState& s) {
  auto g = std::make_shared<api::GraphState>();
  g->submaps.reserve(s.entries.size());
  for (const map::SubmapEntry& e : s.entries) g->submaps.push_back({e.id, e.T_world_submap});
  g->closures.reserve(s.closure_pairs.size());
  for (const slam::ClosurePair& c : s.closure_pairs)
    g->closures.push_back({static_cast<std::uint32_t>(c.from), static_cast<std::uint32_t>(c.to)});
  if (!s.records.empty()) g->stamp_ns = s.records.back().last_stamp_ns;
  // Unchanged (a publication without a new submap or a moved pose) keeps the version.
  const std::shared_ptr<const MappingState> before = state();
  if (before && before->graph && before->graph->closures.size() == g->closures.size() &&
      before->graph->submaps.size() == g->submaps.size() && api::graphUpdate(before->graph.get(), *g).moved.empty()) {
    return before->graph;
  }
  g->version = ++graph_version_;
  return g;
}

void MappingStage::publish() {
  auto s = std::make_shared<MappingState>();
  for (const slam::SubmapRecord& r : pipeline_->submaps()) {
    api::SubmapInfo i;
    i.id = static_cast<std::uint32_t>(r.index);
    i.T_world_submap = r.T_world_base;
    i.n_scans = static_cast<std::uint32_t>(r.n_scans);
    i.first_stamp_ns = r.first_stamp_ns;
    i.last_stamp_ns = r.last_stamp_ns;
    i.closed = true;
    s->submaps.push_back(i);
  }
  s->records = pipeline_->submaps();
  s->entries = pipeline_->map().entries();
  s->closure_pairs = slam::closurePairs(pipeline_->closures());
  s->graph = graphOf(*s);
  s->n_closures = static_cast<std::uint32_t>(pipeline_->closures().size());
  if (!pipeline_->submaps().empty()) {
    const slam::SubmapRecord& r = pipeline_->submaps().back();
    s->T_map_odom = r.T_world_base * r.T_world_base_odom.inverse();
  }
  {
    const std::lock_guard lock(mutex_);
    state_ = std::move(s);
  }
  if (published_) published_();
}

}  // namespace vog::app
