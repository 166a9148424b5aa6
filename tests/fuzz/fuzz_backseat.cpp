#include "vog/backseat/backseat.hpp"
#include "vog/codec/stream_decoder.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto decoded = vog::codec::decodeAll<vog::backseat::BackseatCodec>({data, size});
  vog::backseat::AckTracker tracker;
  for (const auto& s : decoded.frames) {
    (void)vog::backseat::encodeBackseat(s);
    if (const auto* w = std::get_if<vog::backseat::WaypointCommand>(&s)) (void)tracker.send(*w, 0);
    if (const auto* a = std::get_if<vog::backseat::AckSentence>(&s)) (void)tracker.onAck(*a);
  }
  (void)tracker.poll(6'000'000'000);
  return 0;
}
