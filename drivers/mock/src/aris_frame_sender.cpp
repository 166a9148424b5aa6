#include "vog/mock/aris_frame_sender.hpp"

#include "vog/sonar/aris_frame_assembler.hpp"
#include "vog/sonar/aris_reorder.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace vog::mock {

namespace {
// A FramePart is one UDP datagram (at most 65507 bytes of payload): the data, the header and about
// 30 bytes of protobuf tags and varints.
constexpr std::size_t kMaxPartBytes = 64000;
constexpr std::size_t kMaxHeaderBytes = 1024;
constexpr int kMaxRetries = 1000;
}  // namespace

Status ArisFrameSenderConfig::validate() const {
  if (mode != ArisPacketLossMitigation::kDropPartialFrames && mode != ArisPacketLossMitigation::kPessimisticRetry) {
    return Error{"mode: " + std::to_string(static_cast<int>(mode)) + ", must be 0 or 1"};
  }
  if (part_bytes < 1 || part_bytes > kMaxPartBytes) {
    return Error{"part_bytes: " + std::to_string(part_bytes) + ", must be in [1, " + std::to_string(kMaxPartBytes) +
                 "]"};
  }
  if (header_bytes < sonar::kArisFrameHeaderUsedBytes || header_bytes > kMaxHeaderBytes) {
    return Error{"header_bytes: " + std::to_string(header_bytes) + ", must be in [" +
                 std::to_string(sonar::kArisFrameHeaderUsedBytes) + ", " + std::to_string(kMaxHeaderBytes) + "]"};
  }
  if (!(retry_timeout_s > 0.0) || !std::isfinite(retry_timeout_s)) {
    return Error{"retry_timeout_s: " + std::to_string(retry_timeout_s) + ", must be positive and finite"};
  }
  if (max_retries < 0 || max_retries > kMaxRetries) {
    return Error{"max_retries: " + std::to_string(max_retries) + ", must be in [0, " + std::to_string(kMaxRetries) +
                 "]"};
  }
  if (ack_port < 1 || ack_port > 65535) {
    return Error{"ack_port: " + std::to_string(ack_port) + ", must be in [1, 65535]"};
  }
  return Status::success();
}

ArisFrameSender::ArisFrameSender(ArisFrameSenderConfig config) : config_(config) {
  [[maybe_unused]] const Status valid = config_.validate();
  assert(valid.ok());
}

Result<std::vector<ArisFrameSender::Datagram>> ArisFrameSender::send(const sonar::SonarFrame& frame,
                                                                     const sonar::ArisHeaderOptions& header,
                                                                     double now_s) {
  const std::string where = "ARIS frame " + std::to_string(frame.frame_index);
  if (frame.frame_index < 1 ||
      frame.frame_index > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max())) {
    return Error{where + ": frame_index must be in [1, " + std::to_string(std::numeric_limits<std::int32_t>::max()) +
                 "]"};
  }
  if (frame.samples.size() > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    return Error{where + ": " + std::to_string(frame.samples.size()) + " bytes do not fit total_data_size"};
  }
  if (frame.samples.empty()) return Error{where + ": no samples"};
  sonar::ArisHeaderOptions options = header;
  options.reordered_samples = false;
  auto encoded = sonar::encodeArisFrameHeader(frame, options);
  if (!encoded.ok()) return Error{where + ": " + encoded.error().message};
  InFlight f;
  f.frame_index = static_cast<std::int32_t>(frame.frame_index);
  f.header = std::move(*encoded);
  f.header.resize(config_.header_bytes);
  f.data.resize(frame.samples.size());
  const Status reordered = sonar::arisBeamToSonarOrder(options.ping_mode, static_cast<std::uint32_t>(frame.n_samples),
                                                       frame.samples, f.data);
  if (!reordered.ok()) return Error{where + ": " + reordered.error().message};

  if (in_flight_) giveUp(/*for_next_frame=*/true);
  ++stats_.frames_sent;
  std::vector<Datagram> out;
  out.reserve((f.data.size() + config_.part_bytes - 1) / config_.part_bytes);
  appendParts(f, 0, 0, out);
  stats_.datagrams_sent += out.size();
  if (config_.mode == ArisPacketLossMitigation::kPessimisticRetry) {
    f.quiet_since_s = now_s;
    in_flight_ = std::move(f);
  }
  return out;
}

void ArisFrameSender::appendParts(const InFlight& f, std::size_t from, std::size_t max_parts,
                                  std::vector<Datagram>& out) const {
  const std::size_t total = f.data.size();
  std::size_t parts = 0;
  for (std::size_t off = from; off < total && (max_parts == 0 || parts < max_parts); off += config_.part_bytes) {
    const std::size_t n = std::min(config_.part_bytes, total - off);
    out.push_back(sonar::encodeArisFramePart(
        {.frame_index = f.frame_index,
         .total_data_size = static_cast<std::int32_t>(total),
         .header = off == 0 ? std::span<const std::uint8_t>(f.header) : std::span<const std::uint8_t>(),
         .data = std::span(f.data).subspan(off, n),
         .data_offset = static_cast<std::int32_t>(off),
         .ack_port = config_.ack_port}));
    ++parts;
  }
}

ArisAckOutcome ArisFrameSender::onAck(std::span<const std::uint8_t> datagram, double now_s) {
  const auto ack = sonar::decodeArisFramePartAck(datagram);
  if (!ack.ok()) {
    ++stats_.acks_malformed;
    return ArisAckOutcome::kMalformed;
  }
  if (config_.mode == ArisPacketLossMitigation::kDropPartialFrames) {
    ++stats_.acks;
    return ArisAckOutcome::kIgnored;
  }
  if (!in_flight_ || ack->frame_index != in_flight_->frame_index) {
    ++stats_.acks;
    ++stats_.acks_stale;
    return ArisAckOutcome::kStale;
  }
  InFlight& f = *in_flight_;
  const auto total = static_cast<std::int32_t>(f.data.size());
  if (ack->data_offset < 0 || ack->data_offset > total) {
    ++stats_.acks_malformed;
    return ArisAckOutcome::kMalformed;
  }
  ++stats_.acks;
  if (ack->data_offset == total) {
    ++stats_.frames_finished;
    in_flight_.reset();
    return ArisAckOutcome::kFinished;
  }
  if (ack->data_offset <= f.retry_point) return ArisAckOutcome::kNoProgress;
  f.retry_point = ack->data_offset;
  f.quiet_since_s = now_s;
  return ArisAckOutcome::kProgress;
}

std::vector<ArisFrameSender::Datagram> ArisFrameSender::poll(double now_s) {
  std::vector<Datagram> out;
  // Written so that a NaN time resends nothing.
  if (!in_flight_ || !(now_s >= in_flight_->quiet_since_s + config_.retry_timeout_s)) return out;
  InFlight& f = *in_flight_;
  if (f.retries >= config_.max_retries) {
    giveUp(/*for_next_frame=*/false);
    return out;
  }
  ++f.retries;
  ++stats_.retries;
  appendParts(f, static_cast<std::size_t>(f.retry_point), config_.max_parts_per_resend, out);
  stats_.datagrams_sent += out.size();
  stats_.datagrams_resent += out.size();
  f.quiet_since_s = now_s;
  return out;
}

std::optional<double> ArisFrameSender::nextDeadline() const {
  if (!in_flight_) return std::nullopt;
  return in_flight_->quiet_since_s + config_.retry_timeout_s;
}

void ArisFrameSender::giveUp(bool for_next_frame) {
  ++stats_.frames_given_up;
  if (for_next_frame) ++stats_.frames_given_up_for_next;
  in_flight_.reset();
}

}  // namespace vog::mock
