#pragma once
// API framing (proto/README.md "Framing"): every frame is a 4-byte big-endian payload length
// followed by one serialized vog.v1.Envelope. Pure and incremental (STYLE 13): the socket code only
// moves bytes in and out.

#include "vog/core/result.hpp"
#include "vog/v1/api.pb.h"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

namespace vog::api {

inline constexpr std::size_t kFrameHeaderBytes = 4;
// Upper bound of any configured maximum: the length prefix is 32 bits, and protobuf refuses
// messages of 2 GiB or more.
inline constexpr std::uint32_t kFrameBytesLimit = 1u << 30;

// The header + payload of one Envelope, or an error when the payload is larger than
// `max_payload_bytes` (the receiver would refuse it) or cannot be serialized.
Result<std::string> encodeFrame(const v1::Envelope& envelope, std::uint32_t max_payload_bytes = kFrameBytesLimit);
// Appends the frame to `out` (no allocation beyond out's growth); same errors.
Status appendFrame(const v1::Envelope& envelope, std::uint32_t max_payload_bytes, std::string& out);

struct FrameNeedMore {};
struct FrameError {
  enum class Kind : std::uint8_t { kTooLarge, kMalformed };
  Kind kind = Kind::kMalformed;
  std::string message;
};
using FrameResult = std::variant<FrameNeedMore, v1::Envelope, FrameError>;

// Incremental decoder of a byte stream into Envelopes.
// Lifecycle: feed() bytes as they arrive, call next() until it returns FrameNeedMore. After a
// FrameError the decoder is failed for good (length-prefixed framing has no sync marker to recover
// at) and every next() repeats the error. Invariants: an oversize length prefix is reported as soon
// as its 4 bytes are in, before any payload is buffered or allocated; buffered() never exceeds the
// bytes fed and not yet consumed.
class FrameDecoder {
 public:
  explicit FrameDecoder(std::uint32_t max_payload_bytes);

  void feed(std::span<const std::uint8_t> bytes);
  void feed(std::string_view bytes) { feed({reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()}); }
  FrameResult next();

  bool failed() const { return failed_; }
  std::size_t buffered() const { return buffer_.size() - read_; }
  std::uint32_t maxPayloadBytes() const { return max_payload_bytes_; }

 private:
  FrameResult fail(FrameError::Kind kind, std::string message);

  std::uint32_t max_payload_bytes_;
  std::vector<std::uint8_t> buffer_;
  std::size_t read_ = 0;  // consumed prefix of buffer_
  bool failed_ = false;
  FrameError error_;
};

}  // namespace vog::api
