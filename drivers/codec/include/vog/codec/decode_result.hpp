#pragma once
// The one shape every device codec returns (STYLE 13): decoding the bytes at the front of a buffer
// gives a frame (and how many bytes it used), "need more bytes", or "bad: skip N bytes, because ...".
// Codecs are pure: they never read a clock, a socket or a file.
//
// A codec is any type with
//   using Frame = ...;
//   DecodeResult<Frame> decode(std::span<const std::uint8_t> bytes) const;
// that looks only at `bytes` (which start where the previous frame or skip ended).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>

namespace vog::codec {

enum class DecodeStatus : std::uint8_t {
  kFrame,     // a whole, valid frame; consumed() bytes belong to it
  kNeedMore,  // the bytes so far are a valid prefix of a frame; call again with more
  kBad,       // the front of the buffer is not a valid frame; drop consumed() (>= 1) bytes
};

// Why bytes were dropped. Counted separately by StreamDecoder so that a bad checksum (a damaged
// frame) is told apart from line noise between frames.
enum class BadKind : std::uint8_t {
  kNoSync,     // bytes before the next sync pattern (garbage, a partial frame from before we joined)
  kChecksum,   // a structurally valid frame whose checksum / CRC does not match
  kMalformed,  // a sync pattern followed by an impossible header (oversized length, bad field)
};

const char* toString(BadKind kind);

template <class FrameT>
class [[nodiscard]] DecodeResult {
 public:
  using Frame = FrameT;

  static DecodeResult decoded(Frame frame, std::size_t consumed) {
    DecodeResult r(DecodeStatus::kFrame, consumed);
    r.frame_.emplace(std::move(frame));
    return r;
  }
  static DecodeResult needMore() { return DecodeResult(DecodeStatus::kNeedMore, 0); }
  // `skip` is clamped to at least 1 so a caller always makes progress.
  static DecodeResult bad(BadKind kind, std::size_t skip, std::string reason) {
    DecodeResult r(DecodeStatus::kBad, skip == 0 ? 1 : skip);
    r.bad_kind_ = kind;
    r.reason_ = std::move(reason);
    return r;
  }

  DecodeStatus status() const { return status_; }
  bool isFrame() const { return status_ == DecodeStatus::kFrame; }
  bool isNeedMore() const { return status_ == DecodeStatus::kNeedMore; }
  bool isBad() const { return status_ == DecodeStatus::kBad; }

  // Bytes used by the frame (kFrame) or to drop (kBad); 0 for kNeedMore.
  std::size_t consumed() const { return consumed_; }
  Frame& frame() & { return *frame_; }
  const Frame& frame() const& { return *frame_; }
  Frame&& frame() && { return std::move(*frame_); }
  BadKind badKind() const { return bad_kind_; }
  const std::string& reason() const { return reason_; }

 private:
  DecodeResult(DecodeStatus status, std::size_t consumed) : status_(status), consumed_(consumed) {}

  DecodeStatus status_;
  std::size_t consumed_;
  std::optional<Frame> frame_;
  BadKind bad_kind_ = BadKind::kNoSync;
  std::string reason_;
};

inline const char* toString(BadKind kind) {
  switch (kind) {
    case BadKind::kNoSync: return "no sync";
    case BadKind::kChecksum: return "bad checksum";
    case BadKind::kMalformed: return "malformed";
  }
  return "unknown";
}

}  // namespace vog::codec
