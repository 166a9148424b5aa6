#pragma once
// ARIS live frame stream, sending side: what a sonar does with a frame (PROTOCOLS.md "ARIS live
// protocol"; the receiver is vog::sonar::ArisFrameAssembler). Sans-IO like the assembler: the caller
// moves the datagrams and the acks and passes the time; nothing here reads a clock or a socket, so
// the same calls give the same datagrams.
//
// A frame is sent in the sonar's order (arisBeamToSonarOrder) as FramePart datagrams of part_bytes
// data bytes each, the ARIS frame header on the part at data_offset 0 only. The two
// packetLossMitigation modes of SetFrameStreamSettings:
//   kDropPartialFrames: every part is sent once; acks are counted, nothing is resent.
//   kPessimisticRetry: after the parts are out the sender waits for acks. An ack carries the offset of
//     the next byte the receiver expects (N once it holds the whole frame of N bytes). The highest
//     acked offset k is the retry point: when retry_timeout_s passes with no ack raising it (and no
//     send), the sender resends from k (max_parts_per_resend parts, 0 = through the end of the
//     frame) and counts one retry. The frame is finished when an ack says N. It is given up, and
//     counted, when the retry timeout passes after max_retries retries, or when the next frame is
//     sent before it finished (the next frame is due: a sonar never delays a ping for an old frame).

#include "vog/core/result.hpp"
#include "vog/sonar/aris_command.hpp"
#include "vog/sonar/sonar_files.hpp"
#include "vog/sonar/sonar_frame.hpp"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace vog::mock {

using sonar::ArisPacketLossMitigation;

struct ArisFrameSenderConfig {
  ArisPacketLossMitigation mode = ArisPacketLossMitigation::kPessimisticRetry;
  // Frame data bytes per FramePart. 8192 keeps a part with its header (1024 bytes) under a jumbo
  // frame's 9000-byte MTU; 1400 fits a plain Ethernet frame.
  std::size_t part_bytes = 8192;
  // Bytes of the ARIS frame header sent with the first part: at least kArisFrameHeaderUsedBytes (the
  // fields a receiver reads), at most the 1024 of a file's header (the live header is not padded).
  std::size_t header_bytes = 1024;
  // Silence (no ack raising the retry point, no send) after which the sender resends. An ack on a
  // LAN returns well under 1 ms after the part; 10 ms leaves room for a loaded receiver and still
  // allows several retries in the 66.7 ms between frames at the ARIS's fastest 15 frames/s.
  double retry_timeout_s = 0.010;
  // Resend rounds per frame before it is given up (4 x 10 ms, plus the first wait, fits in 66.7 ms).
  int max_retries = 4;
  // Parts sent per resend, from the retry point on; 0 = through the end of the frame. The receiver
  // keeps parts past a gap, so 1 fills one gap per round; 0 fills every gap in one round at the cost
  // of resending parts the receiver may already hold.
  std::size_t max_parts_per_resend = 0;
  std::int32_t ack_port = 56889;  // FramePart.ack_port: where the receiver sends its acks

  // Error naming the key and its value.
  Status validate() const;
};

struct ArisFrameSenderStats {
  std::uint64_t frames_sent = 0;               // frames started by send()
  std::uint64_t frames_finished = 0;           // acked complete (kPessimisticRetry only)
  std::uint64_t frames_given_up = 0;           // unfinished: out of retries, or the next frame came (retry only)
  std::uint64_t frames_given_up_for_next = 0;  // of frames_given_up, those cut short by the next frame
  std::uint64_t datagrams_sent = 0;            // every FramePart, resends included
  std::uint64_t datagrams_resent = 0;
  std::uint64_t retries = 0;         // resend rounds
  std::uint64_t acks = 0;            // well-formed acks, of any frame
  std::uint64_t acks_malformed = 0;  // not a FramePartAck, or an offset outside [0, N] of its frame
  std::uint64_t acks_stale = 0;      // for a frame other than the one being sent (late, or not ours)
};

// What an ack did.
enum class ArisAckOutcome : std::uint8_t {
  kMalformed,   // counted in acks_malformed, otherwise ignored
  kStale,       // another frame's ack, or the frame is already finished or given up
  kNoProgress,  // the frame's ack, not past the retry point (a duplicate, or the receiver missed a part)
  kProgress,    // raised the retry point
  kFinished,    // said N: the frame is finished
  kIgnored,     // kDropPartialFrames: acks are only counted
};

// Lifecycle: construct with a valid config; send() each frame when the sonar pings, with the time;
// onAck() each ack datagram that arrives, with the time; poll() whenever the time reaches
// nextDeadline() (calling it at other times is harmless). Between frames the sender is idle. Times
// are the caller's clock in seconds (any epoch, finite, non-decreasing); a NaN passed to poll()
// resends nothing, and a frame whose timer a NaN broke is given up when the next frame is sent.
// Invariants: at most one frame is in flight; its data (sonar order) and header are kept until it
// finishes or is given up; retry_point only rises and stays in [0, N); retries <= max_retries.
// Not thread-safe: one owner makes every call.
class ArisFrameSender {
 public:
  using Datagram = std::vector<std::uint8_t>;

  // config must pass validate() (asserted: a bad config is the caller's bug).
  explicit ArisFrameSender(ArisFrameSenderConfig config = {});

  // The datagrams of a new frame, to send now in order. frame.samples are in beam order
  // (samples[s * n_beams + b]); the header is encodeArisFrameHeader(frame, header) with
  // ReorderedSamples cleared (the data goes in sonar order). A frame still in flight is given up
  // first. Error, with nothing sent and the frame in flight kept, if frame.frame_index is 0 or above
  // INT32_MAX, the header cannot be encoded (PingMode not of the frame's beams, samples not
  // n_beams x n_samples, ...), or the frame is larger than a FramePart can carry.
  Result<std::vector<Datagram>> send(const sonar::SonarFrame& frame, const sonar::ArisHeaderOptions& header,
                                     double now_s);

  // An ack datagram from the receiver. Acks never resend by themselves: resends come from poll().
  ArisAckOutcome onAck(std::span<const std::uint8_t> datagram, double now_s);

  // The resends due at now_s (empty if none); gives the frame up when its retries are spent.
  std::vector<Datagram> poll(double now_s);

  // When poll() next has something to do; none when no frame awaits acks.
  std::optional<double> nextDeadline() const;

  bool inFlight() const { return in_flight_.has_value(); }
  const ArisFrameSenderStats& stats() const { return stats_; }

 private:
  struct InFlight {
    std::int32_t frame_index = 0;
    std::vector<std::uint8_t> data;    // sonar order, N bytes
    std::vector<std::uint8_t> header;  // header_bytes of the ARIS frame header
    std::int32_t retry_point = 0;      // highest acked offset, < N
    double quiet_since_s = 0.0;        // last send or progress; the retry timer runs from here
    int retries = 0;
  };

  // Appends the parts [from, from + count parts) (clipped to the frame) to out.
  void appendParts(const InFlight& f, std::size_t from, std::size_t max_parts, std::vector<Datagram>& out) const;
  void giveUp(bool for_next_frame);

  ArisFrameSenderConfig config_;
  std::optional<InFlight> in_flight_;  // kPessimisticRetry only: the frame awaiting acks
  ArisFrameSenderStats stats_;
};

}  // namespace vog::mock
