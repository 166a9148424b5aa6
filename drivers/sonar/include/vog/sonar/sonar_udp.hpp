#pragma once
// Live sonar frames over UDP. A 96 x 512 frame (48 kB) does not fit one datagram, so a frame is
// sent as fragments, each a self-describing datagram (little-endian):
//   0  u32 magic "VOGF" (bytes 56 4F 47 46)
//   4  u8  format version (1)
//   5  u8  header size in bytes (68)
//   6  u16 fragment index (0-based)
//   8  u16 fragment count
//   10 u16 payload bytes in this fragment
//   12 u32 frame index
//   16 u32 total sample bytes of the frame (= beams * samples)
//   20 u32 offset of this payload within the frame's samples
//   24 i64 stamp_ns
//   32 u16 beams, 34 u16 samples
//   36 f64 window start m, 44 f64 window length m, 52 f64 sound speed m/s
//   60 u32 reserved (0), 64 u32 reserved (0)
//   68 payload (sample-major bytes [offset, offset + payload bytes))
//   then u32 CRC-32 (IEEE) of everything before it.
// Every fragment repeats the frame metadata, so losing any one fragment loses only that frame.
// The default payload of 1400 bytes keeps a datagram under a 1500-byte Ethernet MTU.

#include "vog/codec/decode_result.hpp"
#include "vog/core/result.hpp"
#include "vog/sonar/sonar_frame.hpp"

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <vector>

namespace vog::sonar {

namespace udp {
constexpr std::size_t kHeaderBytes = 68;
constexpr std::size_t kCrcBytes = 4;
constexpr std::size_t kDefaultPayloadBytes = 1400;
constexpr std::size_t kMaxDatagramBytes = 65507;  // UDP over IPv4
}  // namespace udp

struct SonarFragment {
  std::uint32_t frame_index = 0;
  std::uint16_t fragment_index = 0;
  std::uint16_t fragment_count = 0;
  std::uint32_t total_bytes = 0;
  std::uint32_t offset = 0;
  std::int64_t stamp_ns = 0;
  int n_beams = 0;
  int n_samples = 0;
  double window_start_m = 0.0;
  double window_length_m = 0.0;
  double sound_speed_mps = 0.0;
  std::vector<std::uint8_t> payload;
};

struct SonarUdpLimits {
  int max_beams = 128;
  int max_samples = 4096;
};

// Decodes one fragment from the front of `bytes` (a datagram, or a byte stream of them).
class SonarUdpCodec {
 public:
  using Frame = SonarFragment;
  explicit SonarUdpCodec(SonarUdpLimits limits = {}) : limits_(limits) {}
  codec::DecodeResult<SonarFragment> decode(std::span<const std::uint8_t> bytes) const;

 private:
  SonarUdpLimits limits_;
};

// One datagram per fragment. Error if the frame is inconsistent (samples size) or too large for
// 65535 fragments, or payload_bytes is 0 or makes a datagram larger than UDP allows.
Result<std::vector<std::vector<std::uint8_t>>> encodeSonarDatagrams(
    const SonarFrame& frame, std::size_t payload_bytes = udp::kDefaultPayloadBytes);

struct ReassemblerStats {
  std::uint64_t frames_completed = 0;
  std::uint64_t frames_dropped = 0;      // evicted incomplete (a fragment was lost)
  std::uint64_t fragments_rejected = 0;  // inconsistent with the frame's other fragments
  std::uint64_t fragments_duplicate = 0;
};

// Collects fragments into frames. Lifecycle: add() fragments in any order; a frame is returned
// once all its fragments arrived. Invariants: at most `max_frames_in_flight` partial frames are
// kept (the oldest is dropped and counted); a fragment that disagrees with the first fragment
// of its frame (geometry, count, range) is rejected and counted, never merged.
class FrameReassembler {
 public:
  explicit FrameReassembler(std::size_t max_frames_in_flight = 4) : max_in_flight_(max_frames_in_flight) {}
  std::optional<SonarFrame> add(const SonarFragment& fragment);
  const ReassemblerStats& stats() const { return stats_; }

 private:
  struct Partial {
    SonarFragment first;  // metadata of the frame (payload cleared)
    SonarFrame frame;
    std::vector<bool> received;
    std::size_t received_count = 0;
  };
  std::size_t max_in_flight_;
  std::deque<Partial> partial_;
  ReassemblerStats stats_;
};

}  // namespace vog::sonar
