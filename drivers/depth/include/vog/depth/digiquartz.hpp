#pragma once
// Paroscientific Digiquartz ASCII protocol (Digiquartz "Programming and Operation Manual",
// Ch. 7): a message is '*' + 2-digit destination + 2-digit source + body + CR LF.
// Host commands are sent to the unit (destination 01, source 00), e.g. `*0100P3` (one sample),
// `*0100P4` (continuous samples), `*0100EW*0100UN=2` (set units). Replies from the unit go to the
// host, e.g. `*0001` + `14.6963` (a pressure in the current units) or `*0001UN=2` (a parameter).

#include "vog/codec/decode_result.hpp"
#include "vog/depth/depth_types.hpp"
#include "vog/core/result.hpp"

#include <cstdint>
#include <span>
#include <string>

namespace vog::depth {

// Units codes of the UN command (manual Table "Pressure units").
enum class PressureUnit : int {
  kUserDefined = 0,
  kPsi = 1,
  kHpa = 2,  // = mbar
  kBar = 3,
  kKpa = 4,
  kMpa = 5,
  kInHg = 6,
  kMmHg = 7,
  kMetersOfWater = 8,
};
Result<PressureUnit> pressureUnitFromCode(int code);
// Pascals per unit (m of water: the conventional 9806.65 Pa; inHg and mmHg at 0 deg C).
Result<double> pascalsPerUnit(PressureUnit unit);

struct DigiquartzMessage {
  enum class Kind : std::uint8_t {
    kCommand,    // body is a command word, possibly with "=value" (P3, P4, UN=2, EW)
    kPressure,   // body is a decimal number
    kParameter,  // body is NAME=value from the unit
  };
  Kind kind = Kind::kPressure;
  int destination = 0;
  int source = 1;
  std::string body;            // text after the address, without CR LF
  bool write_enabled = false;  // the command was prefixed by "*ddssEW" (required for settings)
  double value = 0.0;          // the number for kPressure, the value after '=' when numeric otherwise
};

struct DigiquartzDecoderConfig {
  std::size_t max_line_bytes = 64;
};

// Incremental line decoder; a line ends at LF (a preceding CR is optional). Bytes before '*' are
// garbage. A line that is not a valid message (bad address digits, non-numeric reply, too long)
// is dropped as malformed.
class DigiquartzCodec {
 public:
  using Frame = DigiquartzMessage;
  explicit DigiquartzCodec(DigiquartzDecoderConfig config = {}) : config_(config) {}
  codec::DecodeResult<DigiquartzMessage> decode(std::span<const std::uint8_t> bytes) const;

 private:
  DigiquartzDecoderConfig config_;
};

// "*0100P3\r\n" for encodeCommand(1, 0, "P3").
std::string encodeCommand(int destination, int source, const std::string& command);
// "*000114.6963\r\n" for encodePressureReply(0, 1, 14.6963, 4).
std::string encodePressureReply(int destination, int source, double value, int decimals);
std::string encodeParameterReply(int destination, int source, const std::string& name, const std::string& value);

// Turns a pressure reply into a depth sample (UNESCO 1983, see unesco.hpp).
Result<DepthSample> toDepthSample(const DigiquartzMessage& message, const DepthConversionConfig& config,
                                  std::int64_t stamp_ns);

}  // namespace vog::depth
