#pragma once
// DeviceFeed: the decoding half of vogd's device backend (`source: devices`). Every chunk a device
// transport received, with its device and reception stamp, goes in; navigation (odometry) and sonar
// scans with their poses come out. It reads no clock and does no I/O, so `vogd --replay` feeds the
// raw log's records through the same object and gets the same scans, bit for bit.
//
//   dvl       PD0 ensembles (bottom track) or PD6 sentences      -> dead reckoning (x, y)
//   imu       can_frame records (drivers/imu/README.md)          -> dead reckoning (attitude)
//   depth     Digiquartz replies                                  -> dead reckoning (z, UNESCO 1983)
//   sonar     fragment datagrams (sonar_udp.hpp) -> frame -> range extraction -> one scan per ping
//   aris_frames    ARIS FramePart datagrams (aris_frame_assembler.hpp) -> acks out; frame -> the same
//   aris_commands  the ARIS commands vogd sent (aris_command.hpp): the acoustic settings' cookie
//   backseat  $BFNVG / $BFNVR (the vehicle's own navigation), $BFACK (acknowledgements)
//
// Navigation. `kDeadReckoning` (default): odometry is this daemon's dead reckoning from the raw
// sensors; when `align_to_vehicle` is set its position starts at the vehicle's navigated position
// (the first $BFNVG after dead reckoning is initialised), so the odometry frame is the vehicle's
// navigation frame, the frame waypoints are sent in. `kBackseat`: odometry is the vehicle's own
// solution from $BFNVG, interpolated to each ping.
// Scans: a ping is stamped at the reception of its last fragment; its pose is the navigation at that
// stamp. A ping without a pose (navigation not initialised or stale, not yet aligned) is dropped and
// counted, never mapped with a guessed pose.
// ARIS: the commands vogd sent are logged and fed like received bytes, so the feed knows the cookie
// of the last acoustic settings sent; a frame made with other settings (the sonar has not applied
// them yet, refused them, or obeys another client) is dropped and counted, never mapped. Frames
// before any SET_ACOUSTICS was logged are mapped (their header describes them).
//
// Lifecycle: create() with a validated config; feed() in reception order. Invariants: outputs depend
// only on the sequence of feed() calls; odometry stamps never decrease.

#include "vog/app/vehicle_source.hpp"
#include "vog/backseat/backseat.hpp"
#include "vog/backseat/local_tangent_plane.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/depth/depth_types.hpp"
#include "vog/depth/digiquartz.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/dvl/pd6.hpp"
#include "vog/core/result.hpp"
#include "vog/imu/imu_can.hpp"
#include "vog/nav/dead_reckoning.hpp"
#include "vog/slam/submap_builder.hpp"
#include "vog/sonar/aris_frame_assembler.hpp"
#include "vog/sonar/range_extraction.hpp"
#include "vog/sonar/sonar_udp.hpp"

#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace vog::app {

// Raw-log device ids of the device backend (the simulator's records use 0x01xx, scan_record.hpp).
enum class DeviceId : std::uint16_t {
  kDvl = 0x0001,
  kDepth = 0x0002,
  kImu = 0x0003,
  kSonar = 0x0004,
  kBackseat = 0x0005,
  kArisFrames = 0x0006,    // FramePart datagrams as received
  kArisCommands = 0x0007,  // length-prefixed aris.Command messages as sent, one per record
};
inline constexpr std::array<DeviceId, 7> kAllDevices = {
    DeviceId::kDvl,      DeviceId::kDepth,      DeviceId::kImu,         DeviceId::kSonar,
    DeviceId::kBackseat, DeviceId::kArisFrames, DeviceId::kArisCommands};
const char* toString(DeviceId device);
std::optional<DeviceId> deviceIdFromRaw(std::uint16_t raw);

enum class DvlFormat { kPd0, kPd6 };
enum class NavigationSource { kDeadReckoning, kBackseat };

struct DeviceFeedConfig {
  DvlFormat dvl_format = DvlFormat::kPd0;
  depth::DepthConversionConfig depth;
  imu::ImuCanConfig imu;
  sonar::RangeExtractionConfig range_extraction;
  sonar::ArisFrameAssemblerConfig aris_frames;
  nav::DeadReckoningConfig nav;
  NavigationSource navigation = NavigationSource::kDeadReckoning;
  bool align_to_vehicle = true;            // dead reckoning starts at the first $BFNVG position
  backseat::GeoPoint origin{42.0, -71.0};  // world (0, 0) of the backseat's latitude/longitude
  int n_beams = 96;                        // the mapping's fan; a frame with another beam count is refused
  // kBackseat: a ping up to this long after the newest $BFNVG is extrapolated with $BFNVR's velocity.
  double backseat_max_extrapolation_s = 0.5;

  Status validate() const;
};

// The vehicle's navigation as its backseat reports it ($BFNVG, with $BFNVR's speed), world frame.
struct VehicleNavigation {
  std::int64_t stamp_ns = 0;
  geometry::Pose3 T_world_vehicle = geometry::Pose3::Identity();
  Eigen::Vector3d velocity_world_mps = Eigen::Vector3d::Zero();
  int quality = 0;
};

// A FramePartAck to send to the sonar's ack port.
struct ArisAckOut {
  std::int32_t port = 0;
  std::vector<std::uint8_t> datagram;
};

struct FeedOutput {
  std::vector<OdometrySample> odometry;
  std::vector<slam::ScanInput> scans;
  std::vector<backseat::AckSentence> acks;
  std::vector<ArisAckOut> aris_acks;
  std::optional<VehicleNavigation> vehicle_navigation;  // newest in this call
  void clear();
};

struct DeviceCounters {
  std::uint64_t chunks = 0;    // feed() calls
  std::uint64_t messages = 0;  // decoded frames / sentences / samples
  std::uint64_t rejected = 0;  // decoded but refused (bad frame, dead reckoning rejection, ...)
  std::int64_t last_stamp_ns = -1;
  std::string last_error;
};

class DeviceFeed {
 public:
  static Result<DeviceFeed> create(const DeviceFeedConfig& config);

  // Outputs are appended to `out`.
  void feed(DeviceId device, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes, FeedOutput& out);

  const DeviceCounters& counters(DeviceId device) const;
  // The odometry pose at a stamp (what a scan at that stamp is mapped with), or why there is none.
  Result<geometry::Pose3> odometryPoseAt(std::int64_t stamp_ns) const;
  // What a device's decoder dropped, for health: garbage and overflow bytes plus damaged frames.
  std::uint64_t droppedInput(DeviceId device) const;
  nav::NavSolution deadReckoning(std::int64_t now_ns) const { return dead_reckoning_.solution(now_ns); }
  bool aligned() const { return aligned_; }
  const sonar::ArisFrameAssemblerStats& arisFrames() const { return aris_assembler_.stats(); }
  // The cookie of the last SET_ACOUSTICS sent, and of the last frame received since (0: none yet).
  std::uint32_t arisCookieSent() const { return aris_cookie_sent_; }
  std::uint32_t arisCookieReceived() const { return aris_cookie_received_; }
  std::uint64_t arisFramesOtherSettings() const { return aris_frames_other_settings_; }
  std::uint64_t scans() const { return scans_; }
  std::uint64_t scansDropped() const { return scans_dropped_; }
  const std::string& lastDropReason() const { return last_drop_reason_; }

 private:
  DeviceFeed(const DeviceFeedConfig& config, backseat::LocalTangentPlane ltp)
      : config_(config), ltp_(ltp), dead_reckoning_(config.nav), aris_assembler_(config.aris_frames) {}
  DeviceCounters& counter(DeviceId device);
  void reject(DeviceId device, const std::string& why);
  void onDvlAccepted(std::int64_t stamp_ns, FeedOutput& out);
  void onSonarFrame(DeviceId device, const sonar::SonarFrame& frame, std::int64_t stamp_ns, FeedOutput& out);
  void onArisFramePart(std::span<const std::uint8_t> datagram, std::int64_t stamp_ns, FeedOutput& out);
  void onArisCommand(std::span<const std::uint8_t> bytes);
  void onBackseat(backseat::BackseatSentence sentence, std::int64_t stamp_ns, FeedOutput& out);
  Result<geometry::Pose3> backseatPoseAt(std::int64_t stamp_ns) const;
  void addOdometry(std::int64_t stamp_ns, const geometry::Pose3& T, FeedOutput& out);

  DeviceFeedConfig config_;
  backseat::LocalTangentPlane ltp_;
  nav::DeadReckoning dead_reckoning_;
  codec::StreamDecoder<dvl::Pd0Codec> pd0_;
  codec::StreamDecoder<dvl::Pd6Codec> pd6_;
  codec::StreamDecoder<depth::DigiquartzCodec> depth_;
  codec::StreamDecoder<imu::ImuCanCodec> imu_;
  codec::StreamDecoder<backseat::BackseatCodec> backseat_;
  sonar::FrameReassembler reassembler_{8};
  sonar::ArisFrameAssembler aris_assembler_;
  std::uint32_t aris_cookie_sent_ = 0;
  std::uint32_t aris_cookie_received_ = 0;
  std::uint64_t aris_frames_other_settings_ = 0;
  std::array<DeviceCounters, kAllDevices.size()> counters_{};
  std::deque<VehicleNavigation> vehicle_navigation_;                // the last two seconds of $BFNVG
  Eigen::Vector3d vehicle_velocity_mps_ = Eigen::Vector3d::Zero();  // newest $BFNVR
  bool aligned_ = false;
  std::int64_t last_odometry_ns_ = -1;
  std::int64_t last_pd6_stamp_ns_ = -1;
  std::uint64_t scans_ = 0;
  std::uint64_t scans_dropped_ = 0;
  std::string last_drop_reason_;
};

}  // namespace vog::app
