// Sonar UDP: arbitrary datagrams never crash the codec or the reassembler, and a completed frame
// always has consistent geometry.
#include "fuzz_check.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/sonar/sonar_udp.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto decoded = vog::codec::decodeAll<vog::sonar::SonarUdpCodec>({data, size});
  vog::sonar::FrameReassembler reassembler(2);
  for (const auto& fragment : decoded.frames) {
    if (auto frame = reassembler.add(fragment)) {
      VOG_FUZZ_CHECK(frame->samples.size() ==
                     static_cast<std::size_t>(frame->n_beams) * static_cast<std::size_t>(frame->n_samples));
      const auto datagrams = vog::sonar::encodeSonarDatagrams(*frame);
      VOG_FUZZ_CHECK(datagrams.ok());
    }
  }
  return 0;
}
