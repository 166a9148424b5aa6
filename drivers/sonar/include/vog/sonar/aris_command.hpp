#pragma once
// ARIS live protocol, command channel (PROTOCOLS.md "ARIS live protocol"; messages in
// proto/vog/sonar/aris_commands.proto). A client sends the sonar commands over TCP port 56888, each
// one aris.Command prefixed by its length as a 4-byte big-endian integer. This header holds:
//   - our own structs for the commands vogd sends (ArisCommand), their encoding and the sonar-side
//     stream decoder (ArisCommandDecoder), so the mock sonar and the tests speak the real wire format;
//   - validateArisCommand(): the value ranges a device accepts, per model;
//   - deriveArisAcousticSettings(): the raw acoustic settings for the range window an operator asks
//     for, and the window actually achieved after integer rounding.
// Everything is pure: the caller moves the bytes; nothing here reads a clock or a socket.
//
// Value ranges are the ARIS Integration SDK's (SoundMetrics/aris-integration-sdk, see
// docs/devices-and-simulator.md "ARIS acoustic settings" for the files): per model in ArisModelLimits.
//
// Refused commands: the protocol has no negative acknowledgement. The sonar answers a command only
// through later frames (their AppliedSettings cookie). The mock sonar is to ignore
// a refused command and keep its previous settings, so a client sees the old cookie in the frame
// headers, and to close the connection only when the stream itself is broken
// (arisCommandRefusalClosesStream()).

#include "vog/core/result.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace vog::sonar {

// ---- Commands ----

// Availability.systemType values.
enum class ArisSystemType : std::uint8_t { k1800 = 0, k3000 = 1, k1200 = 2 };
enum class ArisFrequency : std::uint8_t { kLow = 0, kHigh = 1 };
// SetSalinity values: the salinity in parts per thousand.
enum class ArisSalinity : std::uint8_t { kFresh = 0, kBrackish = 15, kSaltwater = 35 };
enum class ArisPacketLossMitigation : std::uint8_t { kDropPartialFrames = 0, kPessimisticRetry = 1 };

// SET_DATETIME: the sonar's clock, as "2017-Apr-01 13:24:56" (arisDateTimeText()).
struct ArisSetDateTime {
  std::string date_time;
  bool operator==(const ArisSetDateTime&) const = default;
};

// SET_FRAMESTREAM_RECEIVER: where the sonar sends its frames; ip "0.0.0.0" stops the stream.
struct ArisSetFrameStreamReceiver {
  std::string ip;          // dotted IPv4
  std::uint32_t port = 0;  // UDP, 1-65535 (uint32 on the wire)
  bool operator==(const ArisSetFrameStreamReceiver&) const = default;
};

// SET_FRAMESTREAM_SETTINGS.
struct ArisSetFrameStreamSettings {
  ArisPacketLossMitigation packet_loss_mitigation = ArisPacketLossMitigation::kPessimisticRetry;
  bool interpacket_delay_enable = false;
  std::uint32_t interpacket_delay_us = 0;
  bool operator==(const ArisSetFrameStreamSettings&) const = default;
};

// SET_ACOUSTICS: the raw settings (deriveArisAcousticSettings() computes them from a range window).
struct ArisAcousticSettings {
  std::uint32_t cookie = 0;  // comes back as AppliedSettings in the frames made with these settings
  float frame_rate_hz = 0.0f;
  std::uint32_t samples_per_beam = 0;
  std::uint32_t sample_start_delay_us = 0;
  std::uint32_t cycle_period_us = 0;
  std::uint32_t sample_period_us = 0;
  std::uint32_t pulse_width_us = 0;
  std::uint32_t ping_mode = 0;
  bool enable_transmit = true;
  ArisFrequency frequency = ArisFrequency::kHigh;
  bool enable_150_volts = true;
  float receiver_gain_db = 0.0f;
  bool operator==(const ArisAcousticSettings&) const = default;
};

// SET_SALINITY.
struct ArisSetSalinity {
  ArisSalinity salinity = ArisSalinity::kFresh;
  bool operator==(const ArisSetSalinity&) const = default;
};

// SET_FOCUS: the range the lens focuses at.
struct ArisSetFocus {
  float focus_range_m = 0.0f;
  bool operator==(const ArisSetFocus&) const = default;
};

// PING: keep-alive.
struct ArisPing {
  bool operator==(const ArisPing&) const = default;
};

// One command; its type is the alternative held.
using ArisCommand = std::variant<ArisSetDateTime, ArisSetFrameStreamReceiver, ArisSetFrameStreamSettings,
                                 ArisAcousticSettings, ArisSetSalinity, ArisSetFocus, ArisPing>;

// The wire name of the command's type, e.g. "SET_ACOUSTICS".
std::string_view arisCommandName(const ArisCommand& command);

// The 4-byte big-endian length, then the serialized aris.Command. Every field of the payload is
// written (even at its default), so decode(encode(c)) == c.
std::vector<std::uint8_t> encodeArisCommand(const ArisCommand& command);

// The date and time at `unix_time_s` (UTC) as the sonar takes it: "2017-Apr-01 13:24:56".
std::string arisDateTimeText(std::int64_t unix_time_s);

// ---- Sonar side: stream decoding and validation ----

// Why a command was refused. The first five come from the stream decoder, the rest from
// validateArisCommand().
enum class ArisCommandRefusal : std::uint8_t {
  kLengthOutOfBounds,       // length prefix above max_message_bytes: the stream is out of step, close it
  kUndecodable,             // not an aris.Command (bad bytes, type missing or unknown)
  kUnsupportedType,         // a valid type this implementation does not carry out (telephoto, rotator, ...)
  kPayloadMissing,          // the payload its type needs is absent
  kFieldMissing,            // a field of the payload is absent
  kDateTimeInvalid,         // not "YYYY-Mon-DD HH:MM:SS"
  kReceiverAddressInvalid,  // ip not a dotted IPv4 address
  kReceiverPortInvalid,     // port 0 or above 65535
  kInterpacketDelayOutOfRange,
  kFrameRateOutOfRange,  // NaN, or outside [1, 15] frames/s
  kSamplesPerBeamOutOfRange,
  kSampleStartDelayOutOfRange,
  kSamplePeriodOutOfRange,
  kCyclePeriodOutOfRange,  // outside the model's bounds, or shorter than the sampling it must hold
  kPulseWidthOutOfRange,   // outside the model's bounds for the frequency
  kPingModeUnknown,        // not a ping mode of the model
  kReceiverGainOutOfRange,
  kFocusRangeOutOfRange,  // NaN, negative, or beyond the model's farthest window end
};
inline constexpr std::size_t kArisCommandRefusalCount = 18;
static_assert(static_cast<std::size_t>(ArisCommandRefusal::kFocusRangeOutOfRange) + 1 == kArisCommandRefusalCount);
std::string_view arisCommandRefusalName(ArisCommandRefusal reason);
// True when the stream can no longer be read (the next message boundary is unknown): close it.
bool arisCommandRefusalClosesStream(ArisCommandRefusal reason);

struct ArisCommandDecoderConfig {
  // Largest aris.Command accepted. The largest real one (SET_ACOUSTICS) is under 100 bytes.
  std::size_t max_message_bytes = 64 * 1024;  // in [16, 16 MiB]

  // Error naming the key and its value.
  Status validate() const;
};

// One message read from the stream: a command, or a refusal.
struct ArisDecodedCommand {
  std::optional<ArisCommand> command;
  std::optional<ArisCommandRefusal> refusal;
  std::string refusal_detail;  // what was wrong, with the value; empty unless refused
};

struct ArisCommandDecoderStats {
  std::uint64_t bytes = 0;     // fed, including those ignored after the stream closed
  std::uint64_t messages = 0;  // length-prefixed messages read (commands + refusals, except length)
  std::uint64_t commands = 0;
  std::array<std::uint64_t, kArisCommandRefusalCount> refused{};

  std::uint64_t refusedBy(ArisCommandRefusal reason) const { return refused[static_cast<std::size_t>(reason)]; }
  std::uint64_t refusedTotal() const;
};

// Reads length-prefixed aris.Command messages from a byte stream cut anywhere. A message's payloads
// other than the one its type needs are ignored, as are unknown fields; PING is read with or without
// its empty payload.
// Lifecycle: construct with a valid config, feed() every chunk read from the connection in order;
// once closed() (a length prefix out of bounds), every further byte is ignored and the connection
// should be closed. Invariants: at most 4 + max_message_bytes bytes stay buffered between calls
// (the incomplete tail); a message is delivered once, in stream order. Not thread-safe.
class ArisCommandDecoder {
 public:
  // config must pass validate() (asserted: a bad config is the caller's bug).
  explicit ArisCommandDecoder(ArisCommandDecoderConfig config = {});

  // Every message the bytes complete, in order.
  std::vector<ArisDecodedCommand> feed(std::span<const std::uint8_t> bytes);

  bool closed() const { return closed_; }
  std::size_t buffered() const { return buffer_.size(); }
  const ArisCommandDecoderStats& stats() const { return stats_; }

 private:
  ArisDecodedCommand decodeMessage(std::span<const std::uint8_t> message);
  ArisDecodedCommand refuse(ArisCommandRefusal reason, std::string detail);

  ArisCommandDecoderConfig config_;
  std::vector<std::uint8_t> buffer_;  // the incomplete tail of the stream
  bool closed_ = false;
  ArisCommandDecoderStats stats_;
};

// What a device of `model` would refuse in a decoded command: the reason and the value, or none.
struct ArisCommandCheck {
  ArisCommandRefusal reason;
  std::string detail;
};
std::optional<ArisCommandCheck> validateArisCommand(const ArisCommand& command, ArisSystemType model);

// ---- Acoustic settings from a range window ----

// The limits of one ARIS model (ARIS Integration SDK, SystemConfiguration; times in us).
struct ArisModelLimits {
  std::string_view name;                    // "ARIS 1800"
  std::array<std::uint32_t, 2> ping_modes;  // a model with one ping mode lists it twice
  double window_start_min_m, window_start_max_m;
  double window_end_min_m, window_end_max_m;
  std::uint32_t sample_start_delay_min_us, sample_start_delay_max_us;
  std::uint32_t sample_period_min_us, sample_period_max_us;
  std::uint32_t cycle_period_min_us, cycle_period_max_us;
  struct PulseWidth {
    std::uint32_t min_us, max_us;
    double us_per_m;  // rule of thumb: pulse width = us_per_m x window end
  };
  PulseWidth pulse_high, pulse_low;
  std::uint32_t max_pulse_us_per_s;  // transmit energy: pulse width x frame rate at most this
};
const ArisModelLimits& arisModelLimits(ArisSystemType model);

// Limits common to every model.
inline constexpr std::uint32_t kArisSamplesPerBeamMin = 200;
inline constexpr std::uint32_t kArisSamplesPerBeamMax = 4000;
inline constexpr double kArisFrameRateMinHz = 1.0;
inline constexpr double kArisFrameRateMaxHz = 15.0;
inline constexpr double kArisReceiverGainMaxDb = 24.0;
// Added to the sampling time to make the cycle period (SDK: SystemConfigurationRaw.CyclePeriodMargin).
inline constexpr std::uint32_t kArisCyclePeriodMarginUs = 420;

// Pings per frame of a ping mode (1 -> 3, 3 -> 6, 6 -> 4, 9 -> 8); error for another mode.
Result<int> arisPingsPerFrame(std::uint32_t ping_mode);

// What an operator configures; defaults: an ARIS 1800 in its 96-beam mode looking 1-10 m.
struct ArisSonarConfig {
  ArisSystemType model = ArisSystemType::k1800;
  double window_start_m = 1.0;
  double window_end_m = 10.0;
  double sound_speed_mps = 1480.0;  // in [1400, 1600]
  std::uint32_t ping_mode = 3;      // one of the model's
  double frame_rate_hz = 5.0;       // in [1, 15], and at most what the window allows
  ArisSalinity salinity = ArisSalinity::kFresh;
  ArisFrequency frequency = ArisFrequency::kHigh;
  // Exactly one of the two is non-zero: the samples per beam wanted over the window, or the range
  // covered by one sample. Either is met as closely as the integer sample period allows.
  std::uint32_t samples_per_beam = 1000;  // in [200, 4000]
  double range_resolution_m = 0.0;
  double receiver_gain_db = 18.0;  // in [0, 24]
  bool enable_transmit = true;
  bool enable_150_volts = true;

  // Error naming the key and its value (window and rates against the model's limits).
  Status validate() const;
};

struct ArisDerivedSettings {
  ArisAcousticSettings acoustic;  // cookie 0: ArisSettingsCookies::stamp() sets it
  ArisSetSalinity salinity;
  ArisSetFocus focus;  // the middle of the achieved window
  // The window the settings sample: start = delay x c / 2, end = start + samples x period x c / 2.
  double window_start_m = 0.0;
  double window_end_m = 0.0;
  double sample_length_m = 0.0;
  double max_frame_rate_hz = 0.0;  // the most these settings allow (SDK FrameRate rule)
};

// The raw settings for a config. sample_start_delay = round(2 start / c); the sample period is the
// integer closest to the one wanted, within the model's bounds, then the samples per beam are the
// fewest that reach the window end (raising the period if that needs more than 4000 samples,
// lowering it if fewer than 200); cycle period = delay + samples x period + margin; pulse width by
// the SDK's rule of thumb, capped by the energy limit at the frame rate. Error naming the key when
// the config is invalid or its window cannot be sampled (delay or cycle period out of bounds, frame
// rate above what the window allows).
Result<ArisDerivedSettings> deriveArisAcousticSettings(const ArisSonarConfig& config);

// What a client sends right after connecting, in order: the date, the frame-stream settings, the
// salinity, the acoustic settings (already stamped), the focus, and last the frame-stream receiver,
// so that the first frame the sonar sends is made with these settings.
std::vector<ArisCommand> arisConnectCommands(const ArisDerivedSettings& settings,
                                             const ArisSetFrameStreamSettings& stream,
                                             const ArisSetFrameStreamReceiver& receiver, std::int64_t unix_time_s);

// Gives each distinct set of acoustic settings a new cookie, so a frame's AppliedSettings says
// which settings made it. Lifecycle: one per sonar, kept across reconnections (so no two settings
// share a cookie); stamp() every SET_ACOUSTICS before sending it. Invariant: the cookie changes
// exactly when the settings (other than the cookie) change; it is never 0, so frames made before
// any stamped settings are told apart.
// A sonar keeps its settings when its client goes away, so a client that starts again (a restarted
// vogd) must not reuse the cookies of the one before: it starts its count at `first` (vogd: from
// the wall clock, arisFirstCookie()).
class ArisSettingsCookies {
 public:
  explicit ArisSettingsCookies(std::uint32_t first = 1) : next_(first == 0 ? 1 : first) {}
  // Sets settings.cookie: the last one if the settings are those last stamped, the next otherwise.
  void stamp(ArisAcousticSettings& settings);
  std::uint32_t last() const { return last_.cookie; }

 private:
  ArisAcousticSettings last_{};  // last_.cookie == 0 until the first stamp
  std::uint32_t next_;           // the cookie of the next distinct settings, never 0
};

// A first cookie that differs between runs of a client started at different seconds: the Unix time
// in seconds, folded into [1, 2^31).
std::uint32_t arisFirstCookie(std::int64_t unix_time_s);

}  // namespace vog::sonar
