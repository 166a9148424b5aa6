#pragma once
// HAUV backseat interface: NMEA-like text over TCP (default port 29500). The vehicle sends
// `$BF...*hh` sentences, the payload sends `$BP...*hh`; hh = XOR of the bytes between '$' and '*'
// as two upper-case hex digits; each sentence ends with CR LF (../shared/PROTOCOLS.md).
//
// Sentence fields (comma separated, after the 5-letter name):
//   $BFNVG,hhmmss.ss,ddmm.mmmm,N|S,dddmm.mmmm,E|W,quality,altitude_m,depth_m,heading_deg,roll_deg,pitch_deg,hhmmss.ss
//          (time of the solution, position, 0 = dead reckoning / 1 = GPS fix, altitude above bottom,
//           depth, attitude in degrees, time the solution was computed)
//   $BFNVR,hhmmss.ss,east_mps,north_mps,down_mps,pitch_rate_dps,roll_rate_dps,yaw_rate_dps
//   $BFACK,hhmmss.ss,NAME,hhmmss.ss,id,status,reason        (status 1 accepted, 0 failed)
//   $BPGHP,hhmmss.ss,id,ddmm.mmmm,N|S,dddmm.mmmm,E|W,depth_m,speed_mps[,heading_deg]   (go to position;
//          the optional heading, true degrees in [0, 360), is held on arrival and turned to while
//          moving; without it the vehicle chooses its heading)
// Positions are written with 6 decimals of minutes (2 mm) and read with any number of decimals.
//   $BPSTS,hhmmss.ss,state,text                               (payload heartbeat, every 1 s)
// Other $BF sentences are kept as raw fields (BackseatOther) so nothing is lost.

#include "vog/codec/decode_result.hpp"
#include "vog/core/result.hpp"

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace vog::backseat {

// Time of day carried by the sentences, in seconds since midnight UTC.
struct TimeOfDay {
  double seconds_since_midnight = 0.0;
};

struct NavSentence {          // $BFNVG
  std::int64_t stamp_ns = 0;  // host receive time (set by the driver)
  TimeOfDay time;
  double latitude_deg = 0.0;   // north positive
  double longitude_deg = 0.0;  // east positive
  int quality = 0;
  double altitude_m = 0.0;
  double depth_m = 0.0;
  double heading_deg = 0.0;
  double roll_deg = 0.0;
  double pitch_deg = 0.0;
  TimeOfDay computed_time;
};

struct NavRateSentence {  // $BFNVR
  std::int64_t stamp_ns = 0;
  TimeOfDay time;
  double east_mps = 0.0;
  double north_mps = 0.0;
  double down_mps = 0.0;
  double pitch_rate_dps = 0.0;
  double roll_rate_dps = 0.0;
  double yaw_rate_dps = 0.0;
};

enum class AckStatus : int { kFailed = 0, kAccepted = 1 };

struct AckSentence {  // $BFACK
  std::int64_t stamp_ns = 0;
  TimeOfDay time;
  std::string command;  // acknowledged sentence name, e.g. "BPGHP"
  TimeOfDay command_time;
  std::uint32_t command_id = 0;
  AckStatus status = AckStatus::kAccepted;
  std::string reason;
};

struct WaypointCommand {  // $BPGHP
  TimeOfDay time;
  std::uint32_t id = 0;
  double latitude_deg = 0.0;
  double longitude_deg = 0.0;
  double depth_m = 0.0;
  double speed_mps = 0.0;
  std::optional<double> heading_deg;  // true heading to hold, [0, 360); none: the vehicle's choice
};

struct Heartbeat {  // $BPSTS
  TimeOfDay time;
  int state = 0;  // 0 idle, 1 mapping, 2 planning, 3 fault (payload defined)
  std::string text;
};

struct BackseatOther {
  std::string name;  // e.g. "BFIMU"
  std::vector<std::string> fields;
};

using BackseatSentence =
    std::variant<NavSentence, NavRateSentence, AckSentence, WaypointCommand, Heartbeat, BackseatOther>;

struct BackseatDecoderConfig {
  std::size_t max_sentence_bytes = 256;
};

// Incremental sentence decoder. Bytes before '$' are garbage; a checksum mismatch is a bad
// checksum (dropped up to the line end); a sentence with missing or non-numeric fields is malformed.
class BackseatCodec {
 public:
  using Frame = BackseatSentence;
  explicit BackseatCodec(BackseatDecoderConfig config = {}) : config_(config) {}
  codec::DecodeResult<BackseatSentence> decode(std::span<const std::uint8_t> bytes) const;

 private:
  BackseatDecoderConfig config_;
};

std::uint8_t xorChecksum(std::string_view body);  // over the bytes between '$' and '*'
std::string encodeBackseat(const BackseatSentence& sentence);

// Payload side of the command / acknowledgement exchange: sends a command, resends it after
// `resend_after_ns` until an accepting $BFACK arrives, and gives up after `max_attempts` sends.
// Time is an argument (stamp in ns of a monotonic clock); the tracker never reads a clock.
//
// Lifecycle: send() registers a command and returns the sentence to write now; onAck() settles it;
// poll(now) returns the sentences due for resend and moves exhausted commands to the failed list.
// Invariants: a command id is pending at most once; a settled command is never resent.
struct AckTrackerConfig {
  std::int64_t resend_after_ns = 5'000'000'000;  // PROTOCOLS.md: resend after 5 s
  int max_attempts = 3;                          // PROTOCOLS.md: 3 tries
  Status validate() const;
};

class AckTracker {
 public:
  struct Outcome {
    std::uint32_t command_id = 0;
    bool accepted = false;
    std::string reason;  // from the ACK, or "no acknowledgement after N attempts"
  };

  explicit AckTracker(AckTrackerConfig config = {}) : config_(config) {}

  // The encoded command to send now; error if the id is already pending.
  Result<std::string> send(const WaypointCommand& command, std::int64_t now_ns);
  // Settles the matching pending command; returns its outcome, or an error if nothing matched.
  Result<Outcome> onAck(const AckSentence& ack);
  // Sentences to resend at `now_ns`.
  std::vector<std::string> poll(std::int64_t now_ns);
  // Outcomes of commands that gave up or were acknowledged since the last call.
  std::vector<Outcome> takeOutcomes();
  std::size_t pendingCount() const { return pending_.size(); }

 private:
  struct Pending {
    WaypointCommand command;
    std::string sentence;
    std::int64_t last_sent_ns = 0;
    int attempts = 0;
  };
  AckTrackerConfig config_;
  std::vector<Pending> pending_;
  std::vector<Outcome> outcomes_;
};

// Emits the 1 s $BPSTS heartbeat: due(now) is true when a heartbeat has never been sent or 1 s
// has passed since the last one. Time is an argument. Lifecycle: poll due(), call emit() when due;
// invariant: last_ns_ is the time of the latest emit() and is meaningful only once sent_ is true.
class HeartbeatScheduler {
 public:
  explicit HeartbeatScheduler(std::int64_t period_ns = 1'000'000'000) : period_ns_(period_ns) {}
  bool due(std::int64_t now_ns) const { return !sent_ || now_ns - last_ns_ >= period_ns_; }
  // The encoded heartbeat; records now_ns as the time of the last send.
  std::string emit(const Heartbeat& heartbeat, std::int64_t now_ns);

 private:
  std::int64_t period_ns_;
  std::int64_t last_ns_ = 0;
  bool sent_ = false;
};

}  // namespace vog::backseat
