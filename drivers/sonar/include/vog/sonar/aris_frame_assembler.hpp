#pragma once
// ARIS live frame stream, receiver side (PROTOCOLS.md "ARIS live protocol"; messages in
// proto/vog/sonar/aris_frame_stream.proto). The sonar sends each frame as UDP datagrams, one
// frame_stream.FramePart each; the receiver answers every part with a FramePartAck {frame_index,
// offset of the next expected byte; N once all N bytes of the frame are in}, and in the sonar's
// PESSIMISTIC_RETRY mode the sonar resends from the acknowledged offset until the frame is complete.
// Parsing is pure: the caller moves the datagrams and the acks and passes the time; nothing here
// reads a clock or a socket, so the same datagrams and times give the same results.
//
// Gaps: a part that starts past a gap is kept (not refused). The ack is always the end of the
// contiguous prefix received from byte 0, so it never claims a byte that did not arrive; bytes kept
// past the gap are not acknowledged until the gap is filled, then the ack jumps over them. A
// retransmission of bytes already kept is accepted and counted as a duplicate. Reordered datagrams
// therefore cost no retransmission, and a lost one costs exactly one.

#include "vog/core/result.hpp"
#include "vog/sonar/sonar_files.hpp"
#include "vog/sonar/sonar_frame.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace vog::sonar {

struct ArisFramePartAck {
  std::int32_t frame_index = 0;
  std::int32_t data_offset = 0;  // next expected byte; total_data_size once the frame is complete
  bool operator==(const ArisFramePartAck&) const = default;
};

// The fields of one FramePart to send (the mock sonar's side); header empty on all but the first part.
struct ArisFramePartFields {
  std::int32_t frame_index = 0;
  std::int32_t total_data_size = 0;
  std::span<const std::uint8_t> header;
  std::span<const std::uint8_t> data;
  std::int32_t data_offset = 0;
  std::int32_t ack_port = 0;
};

// Serialized frame_stream.FramePart / FramePartAck.
std::vector<std::uint8_t> encodeArisFramePart(const ArisFramePartFields& part);
std::vector<std::uint8_t> encodeArisFramePartAck(const ArisFramePartAck& ack);
// Error if the bytes are not a FramePartAck with both fields.
Result<ArisFramePartAck> decodeArisFramePartAck(std::span<const std::uint8_t> datagram);

// Why a datagram was refused (not stored, not acknowledged).
enum class ArisPartRefusal : std::uint8_t {
  kUndecodable,            // not a FramePart; frame_index, total_data_size or data_offset missing; frame_index < 1
  kTotalSizeOutOfBounds,   // total_data_size < 1 or above max_beams x max_samples
  kTotalSizeChanged,       // total_data_size differs from the earlier parts of the frame
  kOutsideFrame,           // data_offset outside [0, total_data_size), or the data runs past the end
  kHeaderOnLaterPart,      // a header on a part whose data_offset is not 0
  kHeaderMissing,          // the part at data_offset 0 has no header
  kHeaderShort,            // header shorter than kArisFrameHeaderUsedBytes
  kHeaderInvalid,          // PingMode, SamplesPerBeam, SoundSpeed or SamplePeriod unusable, or
                           // beams x SamplesPerBeam != total_data_size
  kTooFragmented,          // the frame's received bytes would form more than max_ranges_per_frame ranges
  kTooManyFramesInFlight,  // a part of a frame older than the max_frames_in_flight incomplete ones held
};
inline constexpr std::size_t kArisPartRefusalCount = 10;
static_assert(static_cast<std::size_t>(ArisPartRefusal::kTooManyFramesInFlight) + 1 == kArisPartRefusalCount);
std::string_view arisPartRefusalName(ArisPartRefusal reason);

struct ArisFrameAssemblerConfig {
  std::size_t max_frames_in_flight = 4;  // incomplete frames kept at once, at most 64
  // An incomplete frame is dropped this long after its first datagram (a newer frame completing
  // drops it sooner). At the ARIS's 1-15 frames/s a frame older than 2 s is of no use to mapping.
  double max_frame_age_s = 2.0;
  // Bounds of total_data_size: beams x samples of the largest ARIS frame accepted.
  int max_beams = 128;
  int max_samples = 4096;
  // Bounds the work and memory per part when parts arrive scattered (each lost part makes a range).
  std::size_t max_ranges_per_frame = 64;

  // Error naming the key and its value.
  Status validate() const;
};

struct ArisFrameAssemblerStats {
  std::uint64_t datagrams = 0;
  std::uint64_t frames_completed = 0;
  std::uint64_t frames_dropped_incomplete = 0;  // a newer frame completed first or took its place, or too old
  std::uint64_t datagrams_duplicated = 0;       // accepted, but every byte had already arrived
  std::array<std::uint64_t, kArisPartRefusalCount> refused{};

  std::uint64_t refusedBy(ArisPartRefusal reason) const { return refused[static_cast<std::size_t>(reason)]; }
  std::uint64_t refusedTotal() const;
};

// A completed frame: samples in beam/sample order, as decodeArisFile delivers them.
struct ArisLiveFrame {
  SonarFrame frame;
  ArisFrameMeta meta;  // meta.reordered_samples is the header's flag as received
};

// What to do with one datagram.
struct ArisPartResult {
  std::optional<ArisFramePartAck> ack;  // to send to ack_port; none when the datagram is refused
  std::int32_t ack_port = 0;            // FramePart.ack_port, 0 when absent
  std::optional<ArisLiveFrame> frame;   // the frame this datagram completed
  std::optional<ArisPartRefusal> refusal;
  std::string refusal_detail;  // what was wrong, with the value; empty unless refused
};

// Assembles FramePart datagrams into frames.
// Lifecycle: construct with a valid config, then add() every datagram with the time it arrived.
// Invariants: at most max_frames_in_flight incomplete frames are held, each with exactly
// total_data_size bytes of buffer and its received bytes as at most max_ranges_per_frame sorted,
// disjoint ranges; a frame is delivered once, when its ranges are exactly [0, total_data_size);
// its header was checked (PingMode, beams x SamplesPerBeam == total_data_size) before any of its
// bytes were kept, so completing a frame cannot fail. Not thread-safe: one owner calls add().
class ArisFrameAssembler {
 public:
  // config must pass validate() (asserted: a bad config is the caller's bug).
  explicit ArisFrameAssembler(ArisFrameAssemblerConfig config = {});

  // now_s: the caller's clock when the datagram arrived (any epoch, finite, non-decreasing; a NaN
  // or a clock that steps back only delays the age-based drop).
  ArisPartResult add(std::span<const std::uint8_t> datagram, double now_s);

  const ArisFrameAssemblerStats& stats() const { return stats_; }
  std::size_t framesInFlight() const { return partial_.size(); }

 private:
  struct Range {
    std::uint32_t begin;
    std::uint32_t end;
  };
  struct Partial {
    std::int32_t frame_index = 0;
    std::uint32_t total = 0;
    double first_seen_s = 0.0;
    std::vector<std::uint8_t> data;          // total bytes, as received (sonar order unless reordered_samples)
    std::vector<Range> received;             // sorted, disjoint and not touching
    std::optional<ArisLiveFrame> described;  // from the header (part at offset 0): meta, frame without samples
  };
  struct Completed {
    std::int32_t frame_index;
    std::uint32_t total;
    double completed_s;
  };

  void expire(double now_s);
  void dropOlderThan(std::int32_t frame_index);
  ArisPartResult refuse(ArisPartRefusal reason, std::string detail);
  ArisLiveFrame finish(Partial& p);

  ArisFrameAssemblerConfig config_;
  // All three are owned by this assembler and written only by add().
  std::vector<Partial> partial_;      // incomplete frames, in order of their first datagram
  std::vector<Completed> completed_;  // the last few completed frames, so a resent part is acked N
  ArisFrameAssemblerStats stats_;
};

}  // namespace vog::sonar
