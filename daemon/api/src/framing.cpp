#include "vog/api/framing.hpp"

#include <algorithm>
#include <limits>

namespace vog::api {

Status appendFrame(const v1::Envelope& envelope, std::uint32_t max_payload_bytes, std::string& out) {
  const std::size_t size = envelope.ByteSizeLong();
  const std::size_t limit = std::min<std::size_t>(max_payload_bytes, kFrameBytesLimit);
  if (size > limit) {
    return Error{"envelope of " + std::to_string(size) + " bytes exceeds the maximum frame payload of " +
                 std::to_string(limit) + " bytes"};
  }
  const std::size_t at = out.size();
  out.resize(at + kFrameHeaderBytes + size);
  // Big-endian length prefix (proto/README.md "Framing").
  const auto n = static_cast<std::uint32_t>(size);
  out[at + 0] = static_cast<char>((n >> 24) & 0xFF);
  out[at + 1] = static_cast<char>((n >> 16) & 0xFF);
  out[at + 2] = static_cast<char>((n >> 8) & 0xFF);
  out[at + 3] = static_cast<char>(n & 0xFF);
  if (!envelope.SerializeToArray(out.data() + at + kFrameHeaderBytes, static_cast<int>(size))) {
    out.resize(at);
    return Error{"envelope could not be serialized (missing or invalid field)"};
  }
  return {};
}

Result<std::string> encodeFrame(const v1::Envelope& envelope, std::uint32_t max_payload_bytes) {
  std::string out;
  if (Status s = appendFrame(envelope, max_payload_bytes, out); !s.ok()) return s.error();
  return out;
}

FrameDecoder::FrameDecoder(std::uint32_t max_payload_bytes)
    : max_payload_bytes_(std::min(max_payload_bytes, kFrameBytesLimit)) {}

void FrameDecoder::feed(std::span<const std::uint8_t> bytes) {
  if (failed_ || bytes.empty()) return;
  // Drop the consumed prefix before growing, so the buffer holds at most one partial frame plus
  // what was just fed.
  if (read_ > 0 && (read_ == buffer_.size() || read_ >= buffer_.size() / 2)) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(read_));
    read_ = 0;
  }
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
}

FrameResult FrameDecoder::fail(FrameError::Kind kind, std::string message) {
  failed_ = true;
  error_ = FrameError{kind, std::move(message)};
  buffer_.clear();
  buffer_.shrink_to_fit();
  read_ = 0;
  return error_;
}

FrameResult FrameDecoder::next() {
  if (failed_) return error_;
  const std::size_t available = buffer_.size() - read_;
  if (available < kFrameHeaderBytes) return FrameNeedMore{};
  const std::uint8_t* p = buffer_.data() + read_;
  const std::uint32_t length =
      (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
  if (length > max_payload_bytes_) {
    return fail(FrameError::Kind::kTooLarge, "frame length " + std::to_string(length) + " exceeds the maximum of " +
                                                 std::to_string(max_payload_bytes_) + " bytes");
  }
  if (available - kFrameHeaderBytes < length) return FrameNeedMore{};
  v1::Envelope envelope;
  if (!envelope.ParseFromArray(p + kFrameHeaderBytes, static_cast<int>(length))) {
    return fail(FrameError::Kind::kMalformed,
                "frame of " + std::to_string(length) + " bytes is not a valid vog.v1.Envelope");
  }
  read_ += kFrameHeaderBytes + length;
  return envelope;
}

}  // namespace vog::api
