#pragma once
// RDI PD6 ASCII output: one sentence per CR LF line (WorkHorse Commands and Output Data Format,
// PD6 chapter). Velocities are in mm/s on the wire and are the vehicle's motion (sign opposite to
// PD0 bottom track); -32768 marks a bad value. PD6 has no checksum.

#include "vog/codec/decode_result.hpp"
#include "vog/dvl/dvl_types.hpp"

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <variant>

namespace vog::dvl {

// :SA,±PP.PP,±RR.RR,HHH.HH
struct Pd6Attitude {
  double pitch_deg = 0.0;
  double roll_deg = 0.0;
  double heading_deg = 0.0;
};

// :TS,YYMMDDHHmmsshh,SS.S,+TT.T,DDDD.D,CCCC.C,BBB
struct Pd6TimeAndScaling {
  DvlClock clock;
  double salinity_ppt = 0.0;
  double temperature_c = 0.0;
  double transducer_depth_m = 0.0;
  double sound_speed_mps = 0.0;
  int bit_result = 0;
};

// :BI (instrument: x, y, z, error), :BS (ship: transverse, longitudinal, normal),
// :BE (earth: east, north, up), and the water-mass WI/WS/WE equivalents. Status A good, V bad.
struct Pd6Velocity {
  bool bottom = true;  // B* bottom track, W* water mass
  CoordinateFrame frame = CoordinateFrame::kInstrument;
  std::array<double, 3> velocity_mps{};
  std::array<bool, 3> component_valid{};
  bool has_error_velocity = false;  // only the instrument-frame sentences carry it
  double error_velocity_mps = 0.0;
  bool valid = false;  // status 'A'
};

// :BD / :WD,±EEEEEEEE.EE,±NNNNNNNN.NN,±UUUUUUUU.UU,DDDD.DD,TTT.TT
struct Pd6Distance {
  bool bottom = true;
  double east_m = 0.0;
  double north_m = 0.0;
  double up_m = 0.0;
  double range_to_bottom_m = 0.0;
  double time_since_good_s = 0.0;
};

using Pd6Sentence = std::variant<Pd6Attitude, Pd6TimeAndScaling, Pd6Velocity, Pd6Distance>;

struct Pd6DecoderConfig {
  std::size_t max_line_bytes = 128;  // the longest PD6 line (:BD) is about 60 characters
};

// Decodes one line per call. Bytes before a ':' are garbage; an unknown or malformed sentence is
// dropped up to its line end.
class Pd6Codec {
 public:
  using Frame = Pd6Sentence;
  explicit Pd6Codec(Pd6DecoderConfig config = {}) : config_(config) {}
  codec::DecodeResult<Pd6Sentence> decode(std::span<const std::uint8_t> bytes) const;

 private:
  Pd6DecoderConfig config_;
};

// One line, CR LF terminated, in the manual's field widths.
std::string encodePd6(const Pd6Sentence& sentence);

// Vehicle bottom velocity from a PD6 bottom-track velocity sentence.
Result<BottomVelocity> bottomVelocity(const Pd6Velocity& sentence, std::int64_t stamp_ns);

}  // namespace vog::dvl
