#pragma once
// Domain types of the Doppler velocity log (Teledyne RDI Workhorse class), independent of the
// wire format (PD0 binary or PD6 ASCII). Field meanings: RDI "WorkHorse Commands and Output Data
// Format" manual, PD0 and PD6 chapters.

#include "vog/core/result.hpp"

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace vog::dvl {

// Frame of the velocities, from the PD0 coordinate-transform byte (bits 3-4, mask 0x18) or the
// PD6 sentence name (BI instrument, BS ship, BE earth).
enum class CoordinateFrame : std::uint8_t { kBeam = 0, kInstrument = 1, kShip = 2, kEarth = 3 };
const char* toString(CoordinateFrame frame);

// Instrument real-time clock as reported (no time zone; the DVL is usually set to UTC).
struct DvlClock {
  int year = 0;  // full year (Y2K clock if present, else 2000 + yy for yy < 80, 1900 + yy otherwise)
  int month = 0;
  int day = 0;
  int hour = 0;
  int minute = 0;
  int second = 0;
  int hundredths = 0;
};
// Nanoseconds since the Unix epoch, treating the clock as UTC; error if a field is out of range.
Result<std::int64_t> clockToUnixNs(const DvlClock& clock);

struct DvlFixedLeader {
  std::uint8_t firmware_version = 0;
  std::uint8_t firmware_revision = 0;
  std::uint16_t system_configuration = 0;
  int n_beams = 4;
  int n_cells = 0;
  int pings_per_ensemble = 0;
  double cell_length_m = 0.0;
  double blank_m = 0.0;
  std::uint8_t coordinate_transform = 0;  // raw EX byte
  CoordinateFrame coordinate_frame = CoordinateFrame::kBeam;
  bool tilts_used = false;          // EX bit 2
  bool three_beam_allowed = false;  // EX bit 1
  bool bin_mapping = false;         // EX bit 0
  double heading_alignment_deg = 0.0;
  double heading_bias_deg = 0.0;
  double bin1_distance_m = 0.0;
  double transmit_pulse_length_m = 0.0;
  std::uint32_t serial_number = 0;
  int beam_angle_deg = 0;  // 0 if the firmware does not report it
};

struct DvlVariableLeader {
  std::uint32_t ensemble_number = 0;  // including the MSB byte (byte 11)
  DvlClock clock;
  std::uint16_t bit_result = 0;
  double sound_speed_mps = 0.0;
  double transducer_depth_m = 0.0;
  double heading_deg = 0.0;  // 0..360
  double pitch_deg = 0.0;
  double roll_deg = 0.0;
  double salinity_ppt = 0.0;
  double temperature_c = 0.0;
  std::optional<double> pressure_pa;  // present when the leader is long enough (bytes 48..51, daPa)
};

// Bottom track as it is on the wire: per-beam values; in PD0 the four "beam" velocities are
// (b1..b4) in beam coordinates or (x, y, z, error) in the other frames, and they are the motion of
// the bottom relative to the instrument (opposite sign to the vehicle velocity).
struct DvlBottomTrack {
  int pings_per_ensemble = 0;
  std::array<double, 4> range_m{};       // vertical range to the bottom per beam, 0 = none
  std::array<double, 4> velocity_mps{};  // NaN-free: invalid entries are 0 and flagged below
  std::array<bool, 4> velocity_valid{};  // false when the wire value was -32768
  std::array<std::uint8_t, 4> correlation{};
  std::array<std::uint8_t, 4> amplitude{};
  std::array<std::uint8_t, 4> percent_good{};
};

// One PD0 ensemble.
struct DvlEnsemble {
  std::int64_t stamp_ns = 0;  // host receive time; set by the transport, 0 from the codec
  DvlFixedLeader fixed;
  DvlVariableLeader variable;
  // Water-profile velocity per cell, 4 values each (same frame and sign convention as bottom track).
  std::vector<std::array<double, 4>> cell_velocity_mps;
  std::vector<std::array<bool, 4>> cell_velocity_valid;
  std::optional<DvlBottomTrack> bottom_track;
  std::vector<std::uint16_t> data_type_ids;  // in wire order, for display
};

// The vehicle's velocity over the bottom as navigation consumes it: the vehicle's own motion (PD6
// sign, i.e. PD0 bottom-track values negated), in `frame`.
struct BottomVelocity {
  std::int64_t stamp_ns = 0;
  CoordinateFrame frame = CoordinateFrame::kInstrument;
  std::array<double, 3> velocity_mps{};  // x, y, z axes of `frame` (RDI conventions per frame)
  double error_velocity_mps = 0.0;
  bool valid = false;  // true when returned by bottomVelocity(); false = default
  std::array<bool, 4> beam_valid{};
};

// Bottom velocity of an ensemble with bottom track. Beam-frame ensembles are transformed to the
// instrument frame with the 4-beam Janus matrix of the RDI "ADCP Coordinate Transformation"
// manual (Sec. 5.3, convex head); an error names the reason when not possible (no bottom track,
// a bad beam in beam coordinates, unknown beam angle).
Result<BottomVelocity> bottomVelocity(const DvlEnsemble& ensemble);

}  // namespace vog::dvl
