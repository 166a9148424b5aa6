// ARIS frame assembler: arbitrary datagrams never crash it, and its answers keep their invariants:
// a refused datagram gets no ack and no frame, an ack stays within [0, total_data_size], at most
// max_frames_in_flight frames are held, and a completed frame has beams x samples bytes. Besides raw
// datagrams, the input describes parts of small valid frames (mutated offsets, sizes, headers), so
// frames do complete; while no raw datagram was accepted, a completed frame must hold exactly the
// bytes its parts carried.
//
// Input: records [op u8][len u8][len bytes]. op & 1: a raw datagram (the bytes); otherwise a part of
// frame 1 + b[1] % 4 with SamplesPerBeam 1 + b[0] % 8 (48 beams), data_offset b[2] - 1, b[3] bytes,
// the header when offset is 0 (op & 2 inverts that), total_data_size off by op & 4, header cut short
// by op & 8; time advances (op >> 4) * 0.25 s.
#include "fuzz_check.hpp"
#include "vog/sonar/aris_frame_assembler.hpp"
#include "vog/sonar/sonar_files.hpp"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace {

using vog::sonar::ArisFrameAssembler;

// Byte `i` of frame `index`'s data, as every structured part carries it.
std::uint8_t pattern(std::int32_t index, std::size_t i) { return static_cast<std::uint8_t>(index * 31 + i * 7); }

std::vector<std::uint8_t> structuredPart(std::uint8_t op, const std::uint8_t* b, std::size_t n) {
  const auto byte = [&](std::size_t k) { return k < n ? b[k] : std::uint8_t{0}; };
  const int samples = 1 + byte(0) % 8;
  const std::int32_t index = 1 + byte(1) % 4;
  const std::int32_t total = 48 * samples;
  const std::int32_t offset = static_cast<std::int32_t>(byte(2)) - 1;
  const std::int32_t length = byte(3);
  std::vector<std::uint8_t> data;
  for (std::int32_t i = 0; i < length; ++i) data.push_back(pattern(index, static_cast<std::size_t>(offset + i)));
  vog::sonar::SonarFrame f;
  f.frame_index = static_cast<std::uint32_t>(index);
  f.n_beams = 48;
  f.n_samples = samples;
  f.window_start_m = 0.75;
  f.window_length_m = samples * 0.015;
  f.samples.assign(static_cast<std::size_t>(total), 0);
  auto header = *vog::sonar::encodeArisFrameHeader(f, {.ping_mode = 1, .reordered_samples = true});
  if ((op & 8) != 0) header.resize(byte(4) * 4u);
  const bool with_header = (offset == 0) != ((op & 2) != 0);
  return vog::sonar::encodeArisFramePart(
      {.frame_index = index,
       .total_data_size = total + ((op & 4) != 0 ? 48 : 0),
       .header = with_header ? std::span<const std::uint8_t>(header) : std::span<const std::uint8_t>(),
       .data = data,
       .data_offset = offset,
       .ack_port = 700});
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const vog::sonar::ArisFrameAssemblerConfig config{.max_frames_in_flight = 3, .max_ranges_per_frame = 8};
  ArisFrameAssembler assembler(config);
  double now_s = 0.0;
  bool raw_accepted = false;
  std::uint64_t calls = 0;
  std::size_t pos = 0;
  while (pos + 2 <= size) {
    const std::uint8_t op = data[pos];
    const std::size_t len = std::min<std::size_t>(data[pos + 1], size - pos - 2);
    const std::uint8_t* body = data + pos + 2;
    pos += 2 + len;
    now_s += (op >> 4) * 0.25;
    const bool raw = (op & 1) != 0;
    const std::vector<std::uint8_t> datagram =
        raw ? std::vector<std::uint8_t>(body, body + len) : structuredPart(op, body, len);
    const auto r = assembler.add(datagram, now_s);
    ++calls;
    if (r.refusal) {
      VOG_FUZZ_CHECK(!r.ack && !r.frame && !r.refusal_detail.empty());
    } else {
      VOG_FUZZ_CHECK(r.ack && r.ack->data_offset >= 0 && r.ack->frame_index >= 1);
      raw_accepted = raw_accepted || raw;
    }
    if (r.frame) {
      const auto& f = r.frame->frame;
      const auto beams = vog::sonar::arisBeamsForPingMode(r.frame->meta.ping_mode);
      VOG_FUZZ_CHECK(beams.ok() && *beams == f.n_beams);
      VOG_FUZZ_CHECK(f.samples.size() == static_cast<std::size_t>(f.n_beams) * static_cast<std::size_t>(f.n_samples));
      VOG_FUZZ_CHECK(r.ack->data_offset == static_cast<std::int32_t>(f.samples.size()));
      if (!raw_accepted) {
        for (std::size_t i = 0; i < f.samples.size(); ++i) {
          VOG_FUZZ_CHECK(f.samples[i] == pattern(static_cast<std::int32_t>(f.frame_index), i));
        }
      }
    }
    VOG_FUZZ_CHECK(assembler.framesInFlight() <= config.max_frames_in_flight);
  }
  const auto& st = assembler.stats();
  VOG_FUZZ_CHECK(st.datagrams == calls);
  VOG_FUZZ_CHECK(st.refusedTotal() <= calls);
  return 0;
}
