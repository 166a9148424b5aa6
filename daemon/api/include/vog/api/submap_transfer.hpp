#pragma once
// GetSubmap (proto/README.md "Graph and submaps"): a closed submap's grid as its OctoMap .ot bytes, cut
// into slices that are compressed one chunk at a time as the connection drains (SubmapChunks, server),
// and put back together and checked on the client (SubmapAssembler).

#include "vog/api/dispatcher.hpp"
#include "vog/map/local_grid.hpp"
#include "vog/v1/api.pb.h"

#include <cstdint>
#include <memory>
#include <string>

namespace vog::api {

inline constexpr std::uint32_t kDefaultSubmapSliceBytes = 256u << 10;
inline constexpr std::uint32_t kMaxSubmapSliceBytes = 1u << 20;

// The later frames of one GetSubmap reply. The .ot bytes are made when the first chunk is asked for;
// each chunk compresses only its own slice. `slice_bytes` in [1, kMaxSubmapSliceBytes].
std::unique_ptr<ChunkSource> makeSubmapChunks(std::uint64_t request_id, std::uint32_t submap_id,
                                              std::shared_ptr<const map::LocalGrid> grid, std::uint32_t slice_bytes);

v1::SubmapGrid toProto(const map::GridConfig& config);
// Validated (GridConfig::validate names the bad field).
Result<map::GridConfig> fromProto(const v1::SubmapGrid& grid);

// Client side: takes the chunks of one transfer in order and yields the grid.
class SubmapAssembler {
 public:
  explicit SubmapAssembler(std::uint32_t expected_id) : id_(expected_id) {}
  // Checks the chunk belongs (id, the transfer's length, CRC and grid unchanged) and appends its slice.
  Status take(const v1::SubmapChunk& chunk);
  // After the last chunk: the length and CRC-32 checked, the grid made from the .ot.
  Result<std::unique_ptr<map::LocalGrid>> finish() const;
  std::uint64_t compressedBytes() const { return compressed_bytes_; }

 private:
  std::uint32_t id_;
  bool started_ = false;
  std::uint64_t total_ = 0;
  std::uint32_t crc_ = 0;
  map::GridConfig grid_;
  std::string ot_;
  std::uint64_t compressed_bytes_ = 0;
};

}  // namespace vog::api
