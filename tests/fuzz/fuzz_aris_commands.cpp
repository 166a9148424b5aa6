// ARIS command channel, the sonar's side: an arbitrary byte stream never crashes the decoder or the
// checks, and the answers keep their invariants: cutting the stream into chunks changes nothing; a
// refusal has a detail and only a length out of bounds closes the stream (nothing is read after
// it); at most 4 + max_message_bytes bytes stay buffered; the stats add up; and every decoded
// command re-encodes to a message that decodes to the same command (the same bytes again).
//
// Input: [chunk u8][model u8][stream...]: the stream is fed in chunks of 1 + chunk % 32 bytes and
// checked against ARIS model model % 3; then fed again whole, which must give the same results.
#include "fuzz_check.hpp"
#include "vog/sonar/aris_command.hpp"

#include <algorithm>
#include <cstdint>
#include <span>
#include <vector>

namespace {

using vog::sonar::ArisCommandDecoder;
using vog::sonar::ArisDecodedCommand;

constexpr vog::sonar::ArisCommandDecoderConfig kConfig{.max_message_bytes = 256};

bool sameResult(const ArisDecodedCommand& a, const ArisDecodedCommand& b) {
  if (a.refusal != b.refusal || a.refusal_detail != b.refusal_detail ||
      a.command.has_value() != b.command.has_value()) {
    return false;
  }
  // Compared as bytes: a NaN in a float field is not equal to itself.
  return !a.command || vog::sonar::encodeArisCommand(*a.command) == vog::sonar::encodeArisCommand(*b.command);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  const std::size_t chunk = 1 + data[0] % 32;
  const auto model = static_cast<vog::sonar::ArisSystemType>(data[1] % 3);
  const std::span<const std::uint8_t> stream(data + 2, size - 2);

  ArisCommandDecoder decoder(kConfig);
  std::vector<ArisDecodedCommand> results;
  for (std::size_t pos = 0; pos < stream.size(); pos += chunk) {
    const bool was_closed = decoder.closed();
    auto out = decoder.feed(stream.subspan(pos, std::min(chunk, stream.size() - pos)));
    VOG_FUZZ_CHECK(!was_closed || out.empty());
    VOG_FUZZ_CHECK(decoder.buffered() <= 4 + kConfig.max_message_bytes);
    for (auto& r : out) results.push_back(std::move(r));
  }

  std::uint64_t commands = 0;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const auto& r = results[i];
    VOG_FUZZ_CHECK(r.command.has_value() != r.refusal.has_value());
    if (r.refusal) {
      VOG_FUZZ_CHECK(!r.refusal_detail.empty());
      // A stream-closing refusal is the last thing read.
      VOG_FUZZ_CHECK(!vog::sonar::arisCommandRefusalClosesStream(*r.refusal) || i + 1 == results.size());
      continue;
    }
    ++commands;
    const auto check = vog::sonar::validateArisCommand(*r.command, model);
    VOG_FUZZ_CHECK(!check || !check->detail.empty());
    // Re-encoded, the command decodes to itself.
    const auto bytes = vog::sonar::encodeArisCommand(*r.command);
    ArisCommandDecoder again(kConfig);
    const auto back = again.feed(bytes);
    VOG_FUZZ_CHECK(back.size() == 1 && back[0].command && again.buffered() == 0);
    VOG_FUZZ_CHECK(vog::sonar::encodeArisCommand(*back[0].command) == bytes);
    const auto check_back = vog::sonar::validateArisCommand(*back[0].command, model);
    VOG_FUZZ_CHECK(check.has_value() == check_back.has_value() && (!check || check->reason == check_back->reason));
  }

  const auto& st = decoder.stats();
  VOG_FUZZ_CHECK(st.bytes == stream.size());
  VOG_FUZZ_CHECK(st.commands == commands);
  VOG_FUZZ_CHECK(st.commands + st.refusedTotal() == results.size());
  VOG_FUZZ_CHECK(st.messages + st.refusedBy(vog::sonar::ArisCommandRefusal::kLengthOutOfBounds) == results.size());

  // The whole stream at once gives the same results.
  ArisCommandDecoder whole(kConfig);
  const auto at_once = whole.feed(stream);
  VOG_FUZZ_CHECK(at_once.size() == results.size());
  for (std::size_t i = 0; i < results.size(); ++i) VOG_FUZZ_CHECK(sameResult(at_once[i], results[i]));
  VOG_FUZZ_CHECK(whole.closed() == decoder.closed() && whole.buffered() == decoder.buffered());
  return 0;
}
