#include "vog/api/submap_transfer.hpp"

#include <zlib.h>

#include <algorithm>
#include <limits>

namespace vog::api {

namespace {

std::uint32_t crc32Of(std::string_view bytes) {
  uLong crc = crc32(0L, Z_NULL, 0);
  // zlib takes uInt lengths: feed at most 1 GiB at a time.
  for (std::size_t at = 0; at < bytes.size();) {
    const std::size_t n = std::min<std::size_t>(bytes.size() - at, 1u << 30);
    crc = crc32(crc, reinterpret_cast<const Bytef*>(bytes.data() + at), static_cast<uInt>(n));
    at += n;
  }
  return static_cast<std::uint32_t>(crc);
}

class SubmapChunks final : public ChunkSource {
 public:
  SubmapChunks(std::uint64_t request_id, std::uint32_t submap_id, std::shared_ptr<const map::LocalGrid> grid,
               std::uint32_t slice_bytes)
      : request_id_(request_id), submap_id_(submap_id), grid_(std::move(grid)), slice_bytes_(slice_bytes) {}

  bool done() const override { return started_ && index_ >= count_; }
  std::uint64_t requestId() const override { return request_id_; }

  v1::Envelope next() override {
    if (!started_) {
      started_ = true;
      auto ot = grid_->serialize();
      if (!ot) return fail("submap " + std::to_string(submap_id_) + ": " + ot.error().message);
      ot_ = std::move(ot).value();
      crc_ = crc32Of(ot_);
      count_ = std::max<std::size_t>(1, (ot_.size() + slice_bytes_ - 1) / slice_bytes_);
    }
    const std::size_t begin = index_ * slice_bytes_;
    const std::size_t n = std::min<std::size_t>(slice_bytes_, ot_.size() - std::min(ot_.size(), begin));
    std::string compressed(compressBound(static_cast<uLong>(n)), '\0');
    uLongf out_len = static_cast<uLongf>(compressed.size());
    if (compress2(reinterpret_cast<Bytef*>(compressed.data()), &out_len,
                  reinterpret_cast<const Bytef*>(ot_.data() + begin), static_cast<uLong>(n),
                  Z_DEFAULT_COMPRESSION) != Z_OK) {
      return fail("submap " + std::to_string(submap_id_) + ": zlib could not compress a slice");
    }
    compressed.resize(out_len);
    v1::Envelope out;
    out.set_request_id(request_id_);
    auto* chunk = out.mutable_submap_chunk();
    chunk->set_id(submap_id_);
    chunk->set_chunk_index(static_cast<std::uint32_t>(index_));
    chunk->set_chunk_count(static_cast<std::uint32_t>(count_));
    chunk->set_ot_bytes(ot_.size());
    chunk->set_ot_crc32(crc_);
    chunk->set_zlib_slice(std::move(compressed));
    *chunk->mutable_grid() = toProto(grid_->config());
    chunk->set_n_scans(static_cast<std::uint32_t>(grid_->scanCount()));
    if (++index_ >= count_) {
      ot_.clear();
      ot_.shrink_to_fit();
      grid_.reset();
    }
    return out;
  }

 private:
  v1::Envelope fail(std::string message) {
    index_ = count_;
    return makeError(request_id_, v1::ERROR_CODE_INTERNAL, std::move(message));
  }

  std::uint64_t request_id_;
  std::uint32_t submap_id_;
  std::shared_ptr<const map::LocalGrid> grid_;
  std::uint32_t slice_bytes_;
  bool started_ = false;
  std::string ot_;
  std::uint32_t crc_ = 0;
  std::size_t count_ = 1;
  std::size_t index_ = 0;
};

}  // namespace

std::unique_ptr<ChunkSource> makeSubmapChunks(std::uint64_t request_id, std::uint32_t submap_id,
                                              std::shared_ptr<const map::LocalGrid> grid, std::uint32_t slice_bytes) {
  return std::make_unique<SubmapChunks>(request_id, submap_id, std::move(grid), slice_bytes);
}

v1::SubmapGrid toProto(const map::GridConfig& c) {
  v1::SubmapGrid g;
  g.set_resolution_m(c.resolution_m);
  g.set_prob_hit(c.prob_hit);
  g.set_prob_miss(c.prob_miss);
  g.set_clamp_min(c.clamp_min);
  g.set_clamp_max(c.clamp_max);
  g.set_occupancy_threshold(c.occupancy_threshold);
  g.set_max_range_m(c.max_range_m);
  return g;
}

Result<map::GridConfig> fromProto(const v1::SubmapGrid& g) {
  map::GridConfig c;
  c.resolution_m = g.resolution_m();
  c.prob_hit = g.prob_hit();
  c.prob_miss = g.prob_miss();
  c.clamp_min = g.clamp_min();
  c.clamp_max = g.clamp_max();
  c.occupancy_threshold = g.occupancy_threshold();
  c.max_range_m = g.max_range_m();
  if (auto s = c.validate(); !s) return Error{"submap_chunk.grid: " + s.error().message};
  return c;
}

Status SubmapAssembler::take(const v1::SubmapChunk& chunk) {
  const std::string at = "submap " + std::to_string(id_) + " chunk " + std::to_string(chunk.chunk_index()) + ": ";
  if (chunk.id() != id_) return Error{at + "carries submap " + std::to_string(chunk.id())};
  if (!started_) {
    auto grid = fromProto(chunk.grid());
    if (!grid) return Error{at + grid.error().message};
    grid_ = *grid;
    total_ = chunk.ot_bytes();
    crc_ = chunk.ot_crc32();
    if (total_ > (std::uint64_t{1} << 32)) return Error{at + "announces " + std::to_string(total_) + " bytes"};
    ot_.reserve(static_cast<std::size_t>(total_));
    started_ = true;
  } else if (chunk.ot_bytes() != total_ || chunk.ot_crc32() != crc_) {
    return Error{at + "announces another length or CRC than the first chunk"};
  }
  const std::uint64_t room = total_ - ot_.size();
  if (room == 0 && !chunk.zlib_slice().empty()) return Error{at + "holds bytes beyond the announced length"};
  std::string slice(static_cast<std::size_t>(std::min<std::uint64_t>(room, kMaxSubmapSliceBytes)), '\0');
  uLongf n = static_cast<uLongf>(slice.size());
  if (!chunk.zlib_slice().empty()) {
    const int rc = uncompress(reinterpret_cast<Bytef*>(slice.data()), &n,
                              reinterpret_cast<const Bytef*>(chunk.zlib_slice().data()),
                              static_cast<uLong>(chunk.zlib_slice().size()));
    if (rc != Z_OK) return Error{at + "the zlib slice does not decompress (zlib error " + std::to_string(rc) + ")"};
  } else {
    n = 0;
  }
  ot_.append(slice.data(), n);
  compressed_bytes_ += chunk.zlib_slice().size();
  return {};
}

Result<std::unique_ptr<map::LocalGrid>> SubmapAssembler::finish() const {
  const std::string what = "submap " + std::to_string(id_) + ": ";
  if (!started_) return Error{what + "no chunk received"};
  if (ot_.size() != total_) {
    return Error{what + "received " + std::to_string(ot_.size()) + " of " + std::to_string(total_) + " bytes"};
  }
  if (crc32Of(ot_) != crc_) return Error{what + "CRC-32 mismatch"};
  auto grid = map::LocalGrid::deserialize(grid_, ot_);
  if (!grid) return Error{what + grid.error().message};
  return std::move(grid).value();
}

}  // namespace vog::api
