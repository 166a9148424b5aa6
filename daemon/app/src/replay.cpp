#include "vog/app/replay.hpp"

#include "vog/app/device_feed.hpp"
#include "vog/app/scan_record.hpp"
#include "vog/map/merged_map.hpp"
#include "vog/mission/mission_store.hpp"
#include "vog/mission/raw_log.hpp"
#include "vog/slam/mapping_pipeline.hpp"

#include <spdlog/spdlog.h>

#include <optional>

namespace vog::app {

Result<ReplayStats> replayMission(const VogdConfig& config, const std::filesystem::path& mission_dir,
                                  const std::filesystem::path& out_dir) {
  const std::filesystem::path raw_file = mission_dir / mission::MissionStore::kRawLogFile;
  if (std::filesystem::exists(out_dir / mission::MissionStore::kJournalFile))
    return Error{"replay: " + out_dir.string() + " already holds a mission; give an empty or new folder"};
  auto raw = mission::readRawLog(raw_file);
  if (!raw) return Error{"replay: " + raw.error().message};
  ReplayStats stats;
  stats.dropped_segments = raw->dropped_segments;
  if (raw->dropped_segments > 0)
    spdlog::warn(
        "replay: the {} oldest segments of the raw log were dropped while recording "
        "(mission.raw_log_max_bytes); replaying the {} left, from {} ns",
        raw->dropped_segments, raw->segments, raw->records.empty() ? 0 : raw->records.front().stamp_ns);
  auto store = mission::MissionStore::open(out_dir, config.mapping.builder.grid);
  if (!store) return Error{"replay: " + store.error().message};
  auto pipeline = slam::MappingPipeline::create(config.mapping);
  if (!pipeline) return Error{"replay: mapping: " + pipeline.error().message};

  // Device records go through the live run's decoder (source: devices).
  std::optional<DeviceFeed> feed;
  if (config.source == Source::kDevices) {
    auto f = DeviceFeed::create(config.devices.feed);
    if (!f) return Error{"replay: devices: " + f.error().message};
    feed.emplace(std::move(f).value());
  }
  FeedOutput decoded;

  auto persist = [&](const Result<slam::MappingUpdate>& update) -> Status {
    if (!update) {
      ++stats.rejected_scans;  // live mapping refused the same scan and went on
      return {};
    }
    return (*store)->onUpdate(**pipeline, *update);
  };
  bool gate = true;  // scans are mapped unless a gate record says otherwise (scan_record.hpp)
  for (const mission::RawRecord& record : raw->records) {
    if (record.device_id == kSimTruthDeviceId) continue;  // evaluation records, not inputs
    if (record.device_id == kMappingGateDeviceId) {
      if (record.bytes.size() != 1 || record.bytes[0] > 1)
        return Error{"replay: mapping gate record at " + std::to_string(record.stamp_ns) + " ns is malformed"};
      gate = record.bytes[0] == 1;
      continue;
    }
    if (const std::optional<DeviceId> device = deviceIdFromRaw(record.device_id); device && feed) {
      decoded.clear();
      feed->feed(*device, record.stamp_ns, record.bytes, decoded);
      for (const slam::ScanInput& scan : decoded.scans) {
        if (!gate) {
          ++stats.not_mapped;
          continue;
        }
        ++stats.scans;
        if (auto st = persist((*pipeline)->feed(scan)); !st) return st.error();
      }
      continue;
    }
    if (record.device_id != kSimScanDeviceId) {
      ++stats.skipped_records;
      continue;
    }
    auto scan = decodeScanRecord(record.bytes);
    if (!scan) return Error{"replay: record at " + std::to_string(record.stamp_ns) + " ns: " + scan.error().message};
    if (!gate) {
      ++stats.not_mapped;
      continue;
    }
    ++stats.scans;
    if (auto st = persist((*pipeline)->feed(*scan)); !st) return st.error();
  }
  if (auto st = persist((*pipeline)->finish()); !st) return st.error();

  auto merged = map::MergedMap::create(config.mapping.builder.grid);
  if (!merged) return merged.error();
  if (auto s = (*merged)->sync((*pipeline)->map().entries(), config.merge); !s) return s.error();
  if (auto st = (*merged)->writeBt(out_dir / "map.bt"); !st) return st.error();
  stats.submaps = (*pipeline)->submaps().size();
  stats.closures = (*pipeline)->closures().size();
  return stats;
}

}  // namespace vog::app
