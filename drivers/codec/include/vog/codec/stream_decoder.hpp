#pragma once
// Feeds a byte stream through a codec: buffers partial frames, drops garbage until the next sync,
// and counts every frame that was dropped. Transports (serial, TCP, file replay) push bytes in with
// feed() and pull whole frames out with next(); a bad frame is counted and never returned.

#include "vog/codec/decode_result.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace vog::codec {

struct StreamStats {
  std::uint64_t frames = 0;          // frames returned by next()
  std::uint64_t bad_checksum = 0;    // damaged frames dropped (BadKind::kChecksum)
  std::uint64_t malformed = 0;       // impossible headers dropped (BadKind::kMalformed)
  std::uint64_t garbage_bytes = 0;   // bytes dropped while looking for a sync (BadKind::kNoSync)
  std::uint64_t overflow_bytes = 0;  // bytes dropped because the buffer limit was hit
  std::string last_error;            // reason of the most recent drop, empty if none

  std::uint64_t badFrames() const { return bad_checksum + malformed; }
};

// Lifecycle: construct with a codec, then any sequence of feed()/next(); reset() drops buffered bytes
// and keeps the statistics. Invariants: the buffer never holds more than `max_buffered_bytes`
// undecoded bytes (older bytes are dropped and counted as overflow); every byte fed is eventually
// either part of a returned frame, counted as dropped, or still pending (pendingBytes()).
template <class Codec>
class StreamDecoder {
 public:
  using Frame = typename Codec::Frame;

  explicit StreamDecoder(Codec codec = Codec{}, std::size_t max_buffered_bytes = std::size_t{1} << 22)
      : codec_(std::move(codec)), max_buffered_bytes_(max_buffered_bytes) {}

  void feed(std::span<const std::uint8_t> bytes) {
    compact();
    buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
    const std::size_t pending = pendingBytes();
    if (pending > max_buffered_bytes_) {
      const std::size_t drop = pending - max_buffered_bytes_;
      read_pos_ += drop;
      stats_.overflow_bytes += drop;
      stats_.last_error = "stream buffer limit reached, dropped " + std::to_string(drop) + " bytes";
    }
  }

  // The next valid frame, or nullopt when the buffered bytes hold no complete frame yet.
  std::optional<Frame> next() {
    while (read_pos_ < buffer_.size()) {
      const std::span<const std::uint8_t> view(buffer_.data() + read_pos_, buffer_.size() - read_pos_);
      auto result = codec_.decode(view);
      switch (result.status()) {
        case DecodeStatus::kFrame:
          read_pos_ += std::min(result.consumed(), view.size());
          ++stats_.frames;
          return std::move(result).frame();
        case DecodeStatus::kNeedMore: return std::nullopt;
        case DecodeStatus::kBad: {
          const std::size_t skip = std::min(result.consumed(), view.size());
          read_pos_ += skip;
          switch (result.badKind()) {
            case BadKind::kNoSync: stats_.garbage_bytes += skip; break;
            case BadKind::kChecksum: ++stats_.bad_checksum; break;
            case BadKind::kMalformed: ++stats_.malformed; break;
          }
          stats_.last_error = result.reason();
          break;
        }
      }
    }
    return std::nullopt;
  }

  // Bytes buffered but not yet decoded (a partial frame at the end of a recording is truncated).
  std::size_t pendingBytes() const { return buffer_.size() - read_pos_; }
  const StreamStats& stats() const { return stats_; }
  const Codec& codec() const { return codec_; }
  void reset() {
    buffer_.clear();
    read_pos_ = 0;
  }

 private:
  void compact() {
    if (read_pos_ > 0 && (read_pos_ >= buffer_.size() / 2 || read_pos_ == buffer_.size())) {
      buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(read_pos_));
      read_pos_ = 0;
    }
  }

  Codec codec_;
  std::size_t max_buffered_bytes_;
  std::vector<std::uint8_t> buffer_;
  std::size_t read_pos_ = 0;  // first undecoded byte of buffer_
  StreamStats stats_;
};

// Decodes a whole recording in one call: every frame, plus the statistics of what was dropped.
template <class Codec>
struct DecodedStream {
  std::vector<typename Codec::Frame> frames;
  StreamStats stats;
  std::size_t trailing_bytes = 0;  // an incomplete frame at the end
};

template <class Codec>
DecodedStream<Codec> decodeAll(std::span<const std::uint8_t> bytes, Codec codec = Codec{}) {
  StreamDecoder<Codec> decoder(std::move(codec), bytes.size() + 1);
  decoder.feed(bytes);
  DecodedStream<Codec> out;
  while (auto frame = decoder.next()) out.frames.push_back(std::move(*frame));
  out.stats = decoder.stats();
  out.trailing_bytes = decoder.pendingBytes();
  return out;
}

}  // namespace vog::codec
