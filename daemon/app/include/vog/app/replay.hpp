#pragma once
// Offline replay of a recorded mission (`vogd --replay DIR --out OUT`): the raw log's inputs (the
// simulator's scans, or the devices' bytes through the live run's DeviceFeed) are fed, in order and
// through the same mapping gate, to a fresh mapping pipeline with the given configuration, every
// closed submap stored in OUT as a live run stores it, and the merged map written to OUT/map.bt. With the configuration
// the mission ran with, a mission that ran without interruption gives the same submaps bit for bit
// (the mapping side depends only on its inputs). A mission resumed after a crash does not: its submap
// that was open at the crash was lost live but is rebuilt in the replay, and a device run's decoder
// started afresh live where the replay's goes on. A raw log whose oldest segments were dropped (its
// cap, raw_log.hpp) replays what is left, from the gate record each segment starts with.

#include "vog/app/vogd_config.hpp"
#include "vog/core/result.hpp"

#include <cstdint>
#include <filesystem>

namespace vog::app {

struct ReplayStats {
  std::uint64_t scans = 0;
  std::uint64_t skipped_records = 0;  // records of devices this replay does not decode
  std::uint64_t rejected_scans = 0;   // scans the pipeline refused (as live)
  std::uint64_t not_mapped = 0;       // scans outside a mission (the mapping gate, as live)
  std::size_t submaps = 0;
  std::size_t closures = 0;
  std::uint64_t dropped_segments = 0;  // oldest raw log segments dropped while recording (not replayed)
};

// OUT must not hold a mission yet.
Result<ReplayStats> replayMission(const VogdConfig& config, const std::filesystem::path& mission_dir,
                                  const std::filesystem::path& out_dir);

}  // namespace vog::app
