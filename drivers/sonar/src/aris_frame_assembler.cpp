#include "vog/sonar/aris_frame_assembler.hpp"

#include "aris_protobuf.hpp"
#include "vog/sonar/aris_frame_stream.pb.h"
#include "vog/sonar/aris_reorder.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numeric>
#include <utility>

namespace vog::sonar {
namespace {

using detail::parsed;
using detail::serialized;

// Completed frames remembered so that a part resent after a lost final ack is answered N again
// instead of starting the frame over.
constexpr std::size_t kCompletedRemembered = 8;

constexpr std::array<std::string_view, kArisPartRefusalCount> kRefusalNames = {
    "undecodable",          "total_size_out_of_bounds", "total_size_changed", "outside_frame",
    "header_on_later_part", "header_missing",           "header_short",       "header_invalid",
    "too_fragmented",       "too_many_frames_in_flight"};

std::string frameName(std::int32_t frame_index) { return "ARIS frame " + std::to_string(frame_index); }

}  // namespace

std::string_view arisPartRefusalName(ArisPartRefusal reason) { return kRefusalNames[static_cast<std::size_t>(reason)]; }

std::uint64_t ArisFrameAssemblerStats::refusedTotal() const {
  return std::accumulate(refused.begin(), refused.end(), std::uint64_t{0});
}

std::vector<std::uint8_t> encodeArisFramePart(const ArisFramePartFields& part) {
  frame_stream::FramePart msg;
  msg.set_frame_index(part.frame_index);
  msg.set_total_data_size(part.total_data_size);
  if (!part.header.empty()) msg.set_header(part.header.data(), part.header.size());
  msg.set_data(part.data.data(), part.data.size());
  msg.set_data_offset(part.data_offset);
  msg.set_ack_port(part.ack_port);
  return serialized(msg);
}

std::vector<std::uint8_t> encodeArisFramePartAck(const ArisFramePartAck& ack) {
  frame_stream::FramePartAck msg;
  msg.set_frame_index(ack.frame_index);
  msg.set_data_offset(ack.data_offset);
  return serialized(msg);
}

Result<ArisFramePartAck> decodeArisFramePartAck(std::span<const std::uint8_t> datagram) {
  frame_stream::FramePartAck msg;
  if (!parsed(msg, datagram)) {
    return Error{"ARIS FramePartAck: " + std::to_string(datagram.size()) + " bytes do not decode"};
  }
  if (!msg.has_frame_index() || !msg.has_data_offset()) {
    return Error{"ARIS FramePartAck: frame_index or data_offset missing"};
  }
  return ArisFramePartAck{msg.frame_index(), msg.data_offset()};
}

Status ArisFrameAssemblerConfig::validate() const {
  if (max_frames_in_flight < 1 || max_frames_in_flight > 64) {
    return Error{"max_frames_in_flight: " + std::to_string(max_frames_in_flight) + ", must be in [1, 64]"};
  }
  if (!(max_frame_age_s > 0.0) || !std::isfinite(max_frame_age_s)) {
    return Error{"max_frame_age_s: " + std::to_string(max_frame_age_s) + ", must be positive and finite"};
  }
  if (max_beams < 1 || max_beams > 128)
    return Error{"max_beams: " + std::to_string(max_beams) + ", must be in [1, 128]"};
  // 128 x 16384 bytes stays far below INT32_MAX, the largest total_data_size a FramePart can carry.
  if (max_samples < 1 || max_samples > 16384) {
    return Error{"max_samples: " + std::to_string(max_samples) + ", must be in [1, 16384]"};
  }
  if (max_ranges_per_frame < 1 || max_ranges_per_frame > 4096) {
    return Error{"max_ranges_per_frame: " + std::to_string(max_ranges_per_frame) + ", must be in [1, 4096]"};
  }
  return {};
}

ArisFrameAssembler::ArisFrameAssembler(ArisFrameAssemblerConfig config) : config_(config) {
  assert(config_.validate().ok());
  partial_.reserve(config_.max_frames_in_flight);
  completed_.reserve(kCompletedRemembered);
}

ArisPartResult ArisFrameAssembler::refuse(ArisPartRefusal reason, std::string detail) {
  ++stats_.refused[static_cast<std::size_t>(reason)];
  ArisPartResult r;
  r.refusal = reason;
  r.refusal_detail = std::move(detail);
  return r;
}

void ArisFrameAssembler::expire(double now_s) {
  const auto too_old = [&](const Partial& p) { return now_s - p.first_seen_s > config_.max_frame_age_s; };
  const auto dropped = std::erase_if(partial_, too_old);
  stats_.frames_dropped_incomplete += dropped;
  std::erase_if(completed_, [&](const Completed& c) { return now_s - c.completed_s > config_.max_frame_age_s; });
}

void ArisFrameAssembler::dropOlderThan(std::int32_t frame_index) {
  stats_.frames_dropped_incomplete +=
      std::erase_if(partial_, [&](const Partial& p) { return p.frame_index < frame_index; });
}

ArisLiveFrame ArisFrameAssembler::finish(Partial& p) {
  assert(p.described.has_value());  // the part at offset 0 carries the header, checked on arrival
  ArisLiveFrame out = std::move(*p.described);
  if (out.meta.reordered_samples) {
    out.frame.samples = std::move(p.data);
  } else {
    out.frame.samples.resize(p.data.size());
    const Status st = arisSonarToBeamOrder(out.meta.ping_mode, out.meta.samples_per_beam, p.data, out.frame.samples);
    assert(st.ok());  // PingMode and beams x SamplesPerBeam == total were checked with the header
    (void)st;
  }
  return out;
}

ArisPartResult ArisFrameAssembler::add(std::span<const std::uint8_t> datagram, double now_s) {
  ++stats_.datagrams;
  frame_stream::FramePart part;
  if (!parsed(part, datagram)) {
    return refuse(ArisPartRefusal::kUndecodable,
                  "datagram of " + std::to_string(datagram.size()) + " bytes is not a FramePart");
  }
  if (!part.has_frame_index() || !part.has_total_data_size() || !part.has_data_offset()) {
    return refuse(ArisPartRefusal::kUndecodable, "FramePart without frame_index, total_data_size or data_offset");
  }
  const std::int32_t index = part.frame_index();
  if (index < 1) {
    return refuse(ArisPartRefusal::kUndecodable, "FramePart frame_index " + std::to_string(index) + " (1-based)");
  }
  const std::string where = frameName(index);
  expire(now_s);

  const std::int64_t total = part.total_data_size();
  const std::int64_t max_total = static_cast<std::int64_t>(config_.max_beams) * config_.max_samples;
  if (total < 1 || total > max_total) {
    return refuse(ArisPartRefusal::kTotalSizeOutOfBounds, where + ": total_data_size " + std::to_string(total) +
                                                              " outside [1, " + std::to_string(max_total) + "]");
  }
  const std::int64_t offset = part.data_offset();
  const std::int64_t end = offset + static_cast<std::int64_t>(part.data().size());
  if (offset < 0 || offset >= total || end > total) {
    return refuse(ArisPartRefusal::kOutsideFrame, where + ": data [" + std::to_string(offset) + ", " +
                                                      std::to_string(end) + ") outside [0, " + std::to_string(total) +
                                                      ")");
  }

  std::optional<ArisLiveFrame> described;
  if (part.has_header() && offset != 0) {
    return refuse(ArisPartRefusal::kHeaderOnLaterPart,
                  where + ": header on the part at data_offset " + std::to_string(offset));
  }
  if (offset == 0) {
    if (!part.has_header())
      return refuse(ArisPartRefusal::kHeaderMissing, where + ": part at data_offset 0 has no header");
    const auto& h = part.header();
    const auto meta = decodeArisFrameHeader(std::span(reinterpret_cast<const std::uint8_t*>(h.data()), h.size()));
    if (!meta.ok()) return refuse(ArisPartRefusal::kHeaderShort, where + ": " + meta.error().message);
    auto frame = arisFrameFromMeta(*meta, meta->samples_per_beam, {config_.max_beams, config_.max_samples, 1});
    if (!frame.ok()) return refuse(ArisPartRefusal::kHeaderInvalid, where + ": " + frame.error().message);
    const std::int64_t bytes = static_cast<std::int64_t>(frame->n_beams) * frame->n_samples;
    if (bytes != total) {
      return refuse(ArisPartRefusal::kHeaderInvalid,
                    where + ": PingMode " + std::to_string(meta->ping_mode) + " (" + std::to_string(frame->n_beams) +
                        " beams) x SamplesPerBeam " + std::to_string(frame->n_samples) + " = " + std::to_string(bytes) +
                        " bytes, total_data_size " + std::to_string(total));
    }
    described = ArisLiveFrame{std::move(*frame), *meta};
  }

  ArisPartResult result;
  result.ack_port = part.has_ack_port() ? part.ack_port() : 0;
  const auto total_u = static_cast<std::uint32_t>(total);

  if (const auto done = std::find_if(completed_.begin(), completed_.end(),
                                     [&](const Completed& c) { return c.frame_index == index; });
      done != completed_.end()) {
    if (done->total != total_u) {
      return refuse(ArisPartRefusal::kTotalSizeChanged, where + ": total_data_size " + std::to_string(total) +
                                                            ", the frame completed with " +
                                                            std::to_string(done->total));
    }
    ++stats_.datagrams_duplicated;
    result.ack = ArisFramePartAck{index, static_cast<std::int32_t>(total_u)};
    return result;
  }

  auto it = std::find_if(partial_.begin(), partial_.end(), [&](const Partial& p) { return p.frame_index == index; });
  if (it != partial_.end() && it->total != total_u) {
    return refuse(ArisPartRefusal::kTotalSizeChanged, where + ": total_data_size " + std::to_string(total) +
                                                          ", earlier parts said " + std::to_string(it->total));
  }
  // Full: a newer frame takes the place of the oldest incomplete one (in DROP_PARTIAL_FRAMES every
  // lost datagram leaves a frame that never completes; refusing newer frames until those age out
  // would lose whole frames that arrive intact). A part older than every frame held is refused.
  std::vector<Partial>::iterator oldest = partial_.end();
  if (it == partial_.end() && partial_.size() >= config_.max_frames_in_flight) {
    oldest = std::min_element(partial_.begin(), partial_.end(),
                              [](const Partial& x, const Partial& y) { return x.frame_index < y.frame_index; });
    if (oldest->frame_index > index) {
      return refuse(
          ArisPartRefusal::kTooManyFramesInFlight,
          where + ": " + std::to_string(partial_.size()) + " newer frames already incomplete (max_frames_in_flight)");
    }
  }

  // The ranges the part touches (overlapping or adjacent) merge into one.
  const auto begin_u = static_cast<std::uint32_t>(offset);
  const auto end_u = static_cast<std::uint32_t>(end);
  std::vector<Range> no_ranges;
  std::vector<Range>& ranges = it != partial_.end() ? it->received : no_ranges;
  const auto first = std::lower_bound(ranges.begin(), ranges.end(), begin_u,
                                      [](const Range& r, std::uint32_t b) { return r.end < b; });
  auto last = first;
  Range merged{begin_u, end_u};
  std::uint64_t had = 0;  // bytes of [merged) received before
  while (last != ranges.end() && last->begin <= end_u) {
    merged.begin = std::min(merged.begin, last->begin);
    merged.end = std::max(merged.end, last->end);
    had += last->end - last->begin;
    ++last;
  }
  const bool adds_range = begin_u < end_u;
  const std::size_t ranges_after =
      adds_range ? ranges.size() - static_cast<std::size_t>(last - first) + 1 : ranges.size();
  if (ranges_after > config_.max_ranges_per_frame) {
    return refuse(ArisPartRefusal::kTooFragmented,
                  where + ": data [" + std::to_string(offset) + ", " + std::to_string(end) + ") would make " +
                      std::to_string(ranges_after) + " disjoint ranges (max_ranges_per_frame " +
                      std::to_string(config_.max_ranges_per_frame) + ")");
  }

  const bool is_new = it == partial_.end();
  if (oldest != partial_.end()) {
    partial_.erase(oldest);
    ++stats_.frames_dropped_incomplete;
  }
  if (is_new) {
    Partial p;
    p.frame_index = index;
    p.total = total_u;
    p.first_seen_s = now_s;
    p.data.resize(total_u);
    partial_.push_back(std::move(p));
    it = std::prev(partial_.end());
  }
  Partial& p = *it;
  if (adds_range) {
    if (is_new) {
      p.received.push_back(merged);  // first and last point into no_ranges
    } else {
      p.received.insert(p.received.erase(first, last), merged);
    }
    std::copy(part.data().begin(), part.data().end(), p.data.begin() + offset);
  }
  if (!adds_range || (merged.end - merged.begin) == had) ++stats_.datagrams_duplicated;
  if (described && !p.described) p.described = std::move(described);

  const bool complete = p.received.size() == 1 && p.received[0].begin == 0 && p.received[0].end == p.total;
  if (!complete) {
    const std::uint32_t next = !p.received.empty() && p.received[0].begin == 0 ? p.received[0].end : 0;
    result.ack = ArisFramePartAck{index, static_cast<std::int32_t>(next)};
    return result;
  }
  result.frame = finish(p);
  partial_.erase(it);
  ++stats_.frames_completed;
  dropOlderThan(index);
  if (completed_.size() == kCompletedRemembered) completed_.erase(completed_.begin());
  completed_.push_back({index, total_u, now_s});
  result.ack = ArisFramePartAck{index, static_cast<std::int32_t>(total_u)};
  return result;
}

}  // namespace vog::sonar
