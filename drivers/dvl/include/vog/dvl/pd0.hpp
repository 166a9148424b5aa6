#pragma once
// RDI PD0 binary ensembles: incremental decoder and encoder.
// Layout (RDI WorkHorse Commands and Output Data Format, PD0 chapter; checked against
// ../shared/data/pd0/workhorse_*.pd0): header 7F 7F, u16 ensemble size (excluding the checksum),
// spare, u8 number of data types, u16 offset per data type; blocks identified by u16 IDs;
// u16 checksum = byte sum of the ensemble. All little-endian.

#include "vog/codec/decode_result.hpp"
#include "vog/dvl/dvl_types.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace vog::dvl {

namespace pd0 {
constexpr std::uint16_t kFixedLeaderId = 0x0000;
constexpr std::uint16_t kVariableLeaderId = 0x0080;
constexpr std::uint16_t kVelocityId = 0x0100;
constexpr std::uint16_t kCorrelationId = 0x0200;
constexpr std::uint16_t kEchoIntensityId = 0x0300;
constexpr std::uint16_t kPercentGoodId = 0x0400;
constexpr std::uint16_t kBottomTrackId = 0x0600;
constexpr std::int16_t kBadVelocity = -32768;
constexpr std::size_t kFixedLeaderBytes = 59;
constexpr std::size_t kVariableLeaderBytes = 65;
constexpr std::size_t kBottomTrackBytes = 85;  // Navigator / WorkHorse bottom track
}  // namespace pd0

struct Pd0DecoderConfig {
  // Ensembles larger than this are rejected as malformed (the largest WorkHorse ensemble with 128
  // cells and every data type is about 3.3 kB).
  std::size_t max_ensemble_bytes = 8192;
  int max_data_types = 16;
  int max_cells = 255;
};

class Pd0Codec {
 public:
  using Frame = DvlEnsemble;
  explicit Pd0Codec(Pd0DecoderConfig config = {}) : config_(config) {}
  codec::DecodeResult<DvlEnsemble> decode(std::span<const std::uint8_t> bytes) const;

 private:
  Pd0DecoderConfig config_;
};

// Encodes fixed leader, variable leader, velocity (if cells are present) and bottom track (if
// present), with a valid checksum. Values are rounded to the wire resolution.
std::vector<std::uint8_t> encodePd0(const DvlEnsemble& ensemble);

}  // namespace vog::dvl
