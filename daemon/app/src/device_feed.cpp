#include "vog/app/device_feed.hpp"

#include "vog/sonar/aris_command.hpp"

#include <cmath>
#include <numbers>
#include <sstream>
#include <type_traits>
#include <variant>

namespace vog::app {
namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;
constexpr std::int64_t kVehicleNavigationHistoryNs = 2'000'000'000;

std::size_t indexOf(DeviceId device) {
  switch (device) {
    case DeviceId::kDvl: return 0;
    case DeviceId::kDepth: return 1;
    case DeviceId::kImu: return 2;
    case DeviceId::kSonar: return 3;
    case DeviceId::kBackseat: return 4;
    case DeviceId::kArisFrames: return 5;
    case DeviceId::kArisCommands: return 6;
  }
  return 0;
}

std::string seconds(std::int64_t ns) {
  std::ostringstream s;
  s.precision(3);
  s << std::fixed << 1e-9 * static_cast<double>(ns);
  return s.str();
}

}  // namespace

const char* toString(DeviceId device) {
  switch (device) {
    case DeviceId::kDvl: return "dvl";
    case DeviceId::kDepth: return "depth";
    case DeviceId::kImu: return "imu";
    case DeviceId::kSonar: return "sonar";
    case DeviceId::kBackseat: return "backseat";
    case DeviceId::kArisFrames: return "aris_frames";
    case DeviceId::kArisCommands: return "aris_commands";
  }
  return "unknown";
}

std::optional<DeviceId> deviceIdFromRaw(std::uint16_t raw) {
  for (DeviceId d : kAllDevices) {
    if (static_cast<std::uint16_t>(d) == raw) return d;
  }
  return std::nullopt;
}

Status DeviceFeedConfig::validate() const {
  if (Status s = depth.validate(); !s.ok()) return Error{"devices.depth." + s.error().message};
  if (Status s = imu.validate(); !s.ok()) return Error{"devices.imu." + s.error().message};
  if (Status s = range_extraction.validate(); !s.ok())
    return Error{"devices.sonar.range_extraction." + s.error().message};
  if (Status s = aris_frames.validate(); !s.ok()) return Error{"devices.sonar.aris." + s.error().message};
  if (Status s = nav.validate("nav"); !s.ok()) return s;
  if (n_beams < 1 || n_beams > 4096)
    return Error{"devices: the fan's beam count " + std::to_string(n_beams) + " is outside [1, 4096]"};
  if (!(backseat_max_extrapolation_s >= 0.0 && backseat_max_extrapolation_s <= 10.0))
    return Error{"devices.backseat.max_extrapolation_s is outside [0, 10]"};
  if (auto ltp = backseat::LocalTangentPlane::create(origin); !ltp)
    return Error{"devices.backseat.origin: " + ltp.error().message};
  return {};
}

void FeedOutput::clear() {
  odometry.clear();
  scans.clear();
  acks.clear();
  aris_acks.clear();
  vehicle_navigation.reset();
}

Result<DeviceFeed> DeviceFeed::create(const DeviceFeedConfig& config) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  auto ltp = backseat::LocalTangentPlane::create(config.origin);
  if (!ltp) return ltp.error();
  DeviceFeed feed(config, *ltp);
  feed.imu_ = codec::StreamDecoder<imu::ImuCanCodec>(imu::ImuCanCodec(config.imu));
  return feed;
}

DeviceCounters& DeviceFeed::counter(DeviceId device) { return counters_[indexOf(device)]; }
const DeviceCounters& DeviceFeed::counters(DeviceId device) const { return counters_[indexOf(device)]; }

std::uint64_t DeviceFeed::droppedInput(DeviceId device) const {
  auto dropped = [](const codec::StreamStats& s) { return s.garbage_bytes + s.overflow_bytes + s.badFrames(); };
  switch (device) {
    case DeviceId::kDvl: return dropped(pd0_.stats()) + dropped(pd6_.stats());
    case DeviceId::kDepth: return dropped(depth_.stats());
    case DeviceId::kImu: return dropped(imu_.stats());
    case DeviceId::kSonar: {
      const sonar::ReassemblerStats& r = reassembler_.stats();
      return r.frames_dropped + r.fragments_rejected;
    }
    case DeviceId::kBackseat: return dropped(backseat_.stats());
    case DeviceId::kArisFrames: {
      const sonar::ArisFrameAssemblerStats& a = aris_assembler_.stats();
      return a.frames_dropped_incomplete + a.refusedTotal();
    }
    case DeviceId::kArisCommands: return 0;
  }
  return 0;
}

void DeviceFeed::reject(DeviceId device, const std::string& why) {
  DeviceCounters& c = counter(device);
  ++c.rejected;
  c.last_error = why;
}

void DeviceFeed::feed(DeviceId device, std::int64_t stamp_ns, std::span<const std::uint8_t> bytes, FeedOutput& out) {
  DeviceCounters& c = counter(device);
  ++c.chunks;
  c.last_stamp_ns = stamp_ns;
  switch (device) {
    case DeviceId::kDvl:
      if (config_.dvl_format == DvlFormat::kPd0) {
        pd0_.feed(bytes);
        while (auto e = pd0_.next()) {
          ++c.messages;
          e->stamp_ns = stamp_ns;
          if (Status s = dead_reckoning_.addDvl(*e); !s.ok()) {
            reject(device, s.error().message);
            continue;
          }
          onDvlAccepted(stamp_ns, out);
        }
      } else {
        pd6_.feed(bytes);
        while (auto sentence = pd6_.next()) {
          ++c.messages;
          const auto* v = std::get_if<dvl::Pd6Velocity>(&*sentence);
          if (v == nullptr || !v->bottom) continue;  // attitude, time, distance, water mass: not used
          auto velocity = dvl::bottomVelocity(*v, stamp_ns);
          if (!velocity) {
            reject(device, velocity.error().message);
            continue;
          }
          // One ensemble gives the same velocity in several frames (BI, BS, BE); within one chunk
          // they share a stamp and only the first is integrated.
          if (stamp_ns == last_pd6_stamp_ns_) continue;
          last_pd6_stamp_ns_ = stamp_ns;
          if (Status s = dead_reckoning_.addDvl(*velocity); !s.ok()) {
            reject(device, s.error().message);
            continue;
          }
          onDvlAccepted(stamp_ns, out);
        }
      }
      break;
    case DeviceId::kDepth:
      depth_.feed(bytes);
      while (auto m = depth_.next()) {
        ++c.messages;
        if (m->kind != depth::DigiquartzMessage::Kind::kPressure) continue;  // parameter replies, echoes
        auto sample = depth::toDepthSample(*m, config_.depth, stamp_ns);
        if (!sample) {
          reject(device, sample.error().message);
          continue;
        }
        if (Status s = dead_reckoning_.addDepth(*sample); !s.ok()) reject(device, s.error().message);
      }
      break;
    case DeviceId::kImu:
      imu_.feed(bytes);
      while (auto sample = imu_.next()) {
        ++c.messages;
        sample->stamp_ns = stamp_ns;
        if (Status s = dead_reckoning_.addImu(*sample); !s.ok()) reject(device, s.error().message);
      }
      break;
    case DeviceId::kSonar: {
      auto r = sonar::SonarUdpCodec{}.decode(bytes);
      if (!r.isFrame()) {
        reject(device, r.isBad() ? r.reason() : "truncated datagram");
        break;
      }
      ++c.messages;
      if (auto frame = reassembler_.add(r.frame())) onSonarFrame(device, *frame, stamp_ns, out);
      break;
    }
    case DeviceId::kArisFrames: onArisFramePart(bytes, stamp_ns, out); break;
    case DeviceId::kArisCommands: onArisCommand(bytes); break;
    case DeviceId::kBackseat:
      backseat_.feed(bytes);
      while (auto sentence = backseat_.next()) {
        ++c.messages;
        onBackseat(std::move(*sentence), stamp_ns, out);
      }
      break;
  }
}

Result<geometry::Pose3> DeviceFeed::odometryPoseAt(std::int64_t stamp_ns) const {
  if (config_.navigation == NavigationSource::kBackseat) return backseatPoseAt(stamp_ns);
  if (config_.align_to_vehicle && !aligned_)
    return Error{"dead reckoning not yet aligned to the vehicle's navigation ($BFNVG)"};
  return dead_reckoning_.poseAt(stamp_ns);
}

Result<geometry::Pose3> DeviceFeed::backseatPoseAt(std::int64_t stamp_ns) const {
  if (vehicle_navigation_.empty()) return Error{"no vehicle navigation ($BFNVG) yet"};
  const VehicleNavigation& newest = vehicle_navigation_.back();
  if (stamp_ns >= newest.stamp_ns) {
    const std::int64_t ahead_ns = stamp_ns - newest.stamp_ns;
    if (1e-9 * static_cast<double>(ahead_ns) > config_.backseat_max_extrapolation_s)
      return Error{"newest vehicle navigation is " + seconds(ahead_ns) + " s old"};
    geometry::Pose3 T = newest.T_world_vehicle;
    T.translation() += 1e-9 * static_cast<double>(ahead_ns) * vehicle_velocity_mps_;
    return T;
  }
  for (std::size_t i = vehicle_navigation_.size() - 1; i > 0; --i) {
    const VehicleNavigation& a = vehicle_navigation_[i - 1];
    const VehicleNavigation& b = vehicle_navigation_[i];
    if (stamp_ns < a.stamp_ns) continue;
    const double f = static_cast<double>(stamp_ns - a.stamp_ns) / static_cast<double>(b.stamp_ns - a.stamp_ns);
    geometry::Pose3 T = geometry::Pose3::Identity();
    T.linear() = Eigen::Quaterniond(a.T_world_vehicle.linear())
                     .slerp(f, Eigen::Quaterniond(b.T_world_vehicle.linear()))
                     .normalized()
                     .toRotationMatrix();
    T.translation() = (1.0 - f) * a.T_world_vehicle.translation() + f * b.T_world_vehicle.translation();
    return T;
  }
  return Error{"the stamp is older than the kept vehicle navigation"};
}

void DeviceFeed::addOdometry(std::int64_t stamp_ns, const geometry::Pose3& T, FeedOutput& out) {
  if (stamp_ns < last_odometry_ns_) return;
  last_odometry_ns_ = stamp_ns;
  OdometrySample o;
  o.stamp_ns = stamp_ns;
  o.T_odom_vehicle = T;
  if (config_.navigation == NavigationSource::kDeadReckoning) {
    const nav::NavSolution s = dead_reckoning_.solution(stamp_ns);
    o.sigma_xyz_m = Eigen::Vector3d(s.position_sigma_m, s.position_sigma_m, 0.0);
    o.sigma_yaw_rad = config_.nav.heading_sigma_rad;
  }
  out.odometry.push_back(o);
}

void DeviceFeed::onDvlAccepted(std::int64_t stamp_ns, FeedOutput& out) {
  if (config_.navigation != NavigationSource::kDeadReckoning) return;
  auto T = odometryPoseAt(stamp_ns);
  if (T) addOdometry(stamp_ns, *T, out);
}

void DeviceFeed::onArisFramePart(std::span<const std::uint8_t> datagram, std::int64_t stamp_ns, FeedOutput& out) {
  sonar::ArisPartResult r = aris_assembler_.add(datagram, 1e-9 * static_cast<double>(stamp_ns));
  if (r.refusal) {
    reject(DeviceId::kArisFrames, r.refusal_detail);
    return;
  }
  ++counter(DeviceId::kArisFrames).messages;
  if (r.ack && r.ack_port > 0 && r.ack_port <= 65535) {
    out.aris_acks.push_back({r.ack_port, sonar::encodeArisFramePartAck(*r.ack)});
  }
  if (!r.frame) return;
  const std::uint32_t cookie = r.frame->meta.settings_cookie;
  aris_cookie_received_ = cookie;
  if (aris_cookie_sent_ != 0 && cookie != aris_cookie_sent_) {
    ++aris_frames_other_settings_;
    ++scans_dropped_;
    last_drop_reason_ = "frame " + std::to_string(r.frame->frame.frame_index) + " made with settings " +
                        std::to_string(cookie) + ", not the " + std::to_string(aris_cookie_sent_) + " sent";
    return;
  }
  onSonarFrame(DeviceId::kArisFrames, r.frame->frame, stamp_ns, out);
}

void DeviceFeed::onArisCommand(std::span<const std::uint8_t> bytes) {
  // One record is one whole message as sent; a fresh decoder reads it.
  sonar::ArisCommandDecoder decoder;
  for (const sonar::ArisDecodedCommand& d : decoder.feed(bytes)) {
    if (!d.command) {
      reject(DeviceId::kArisCommands, d.refusal_detail);
      continue;
    }
    ++counter(DeviceId::kArisCommands).messages;
    if (const auto* acoustic = std::get_if<sonar::ArisAcousticSettings>(&*d.command)) {
      aris_cookie_sent_ = acoustic->cookie;
      aris_cookie_received_ = 0;  // no frame yet since these were sent (the sonar may have rebooted)
    }
  }
  if (decoder.buffered() > 0) reject(DeviceId::kArisCommands, "a record ends inside a command");
}

void DeviceFeed::onSonarFrame(DeviceId device, const sonar::SonarFrame& frame, std::int64_t stamp_ns, FeedOutput& out) {
  auto drop = [&](const std::string& why) {
    ++scans_dropped_;
    last_drop_reason_ = why;
  };
  if (frame.n_beams != config_.n_beams) {
    reject(device, "frame " + std::to_string(frame.frame_index) + " has " + std::to_string(frame.n_beams) +
                       " beams, the mapping's fan " + std::to_string(config_.n_beams));
    drop("beam count");
    return;
  }
  auto ranges = sonar::extractRanges(frame, config_.range_extraction);
  if (!ranges) {
    reject(device, "frame " + std::to_string(frame.frame_index) + ": " + ranges.error().message);
    drop("range extraction: " + ranges.error().message);
    return;
  }
  auto T = odometryPoseAt(stamp_ns);
  if (!T) {
    drop("no pose: " + T.error().message);
    return;
  }
  slam::ScanInput in;
  in.T_world_vehicle_odom = *T;
  const Eigen::Vector3d rpy = geometry::rpyFromRotation(T->linear());
  in.z_roll_pitch = Eigen::Vector3d(T->translation().z(), rpy.x(), rpy.y());
  in.scan = std::move(ranges).value();
  in.scan.stamp_ns = stamp_ns;
  out.scans.push_back(std::move(in));
  ++scans_;
}

void DeviceFeed::onBackseat(backseat::BackseatSentence sentence, std::int64_t stamp_ns, FeedOutput& out) {
  if (auto* ack = std::get_if<backseat::AckSentence>(&sentence)) {
    ack->stamp_ns = stamp_ns;
    out.acks.push_back(std::move(*ack));
    return;
  }
  if (const auto* rate = std::get_if<backseat::NavRateSentence>(&sentence)) {
    vehicle_velocity_mps_ = Eigen::Vector3d(rate->east_mps, rate->north_mps, -rate->down_mps);
    if (!vehicle_velocity_mps_.allFinite()) vehicle_velocity_mps_.setZero();
    if (!vehicle_navigation_.empty()) vehicle_navigation_.back().velocity_world_mps = vehicle_velocity_mps_;
    if (out.vehicle_navigation) out.vehicle_navigation->velocity_world_mps = vehicle_velocity_mps_;
    return;
  }
  const auto* nvg = std::get_if<backseat::NavSentence>(&sentence);
  if (nvg == nullptr) return;
  if (!vehicle_navigation_.empty() && stamp_ns <= vehicle_navigation_.back().stamp_ns) {
    reject(DeviceId::kBackseat, "$BFNVG at " + std::to_string(stamp_ns) + " ns is not after the previous");
    return;
  }
  VehicleNavigation v;
  v.stamp_ns = stamp_ns;
  v.quality = nvg->quality;
  const Eigen::Vector2d xy = ltp_.toLocal({nvg->latitude_deg, nvg->longitude_deg});
  v.T_world_vehicle.linear() =
      nav::worldFromNedAttitude(nvg->roll_deg * kDegToRad, nvg->pitch_deg * kDegToRad, nvg->heading_deg * kDegToRad);
  v.T_world_vehicle.translation() = Eigen::Vector3d(xy.x(), xy.y(), -nvg->depth_m);
  v.velocity_world_mps = vehicle_velocity_mps_;
  if (!v.T_world_vehicle.translation().allFinite() || !geometry::isValidPose(v.T_world_vehicle)) {
    reject(DeviceId::kBackseat, "$BFNVG gives no valid pose");
    return;
  }
  vehicle_navigation_.push_back(v);
  while (vehicle_navigation_.size() > 2 &&
         stamp_ns - vehicle_navigation_.front().stamp_ns > kVehicleNavigationHistoryNs)
    vehicle_navigation_.pop_front();
  out.vehicle_navigation = v;

  if (config_.navigation == NavigationSource::kBackseat) {
    addOdometry(stamp_ns, v.T_world_vehicle, out);
    return;
  }
  if (config_.align_to_vehicle && !aligned_) {
    // Move dead reckoning so that it agrees with the vehicle at this stamp.
    auto T = dead_reckoning_.poseAt(stamp_ns);
    if (!T) return;  // not initialised yet: align at a later sentence
    const Eigen::Vector2d now = dead_reckoning_.solution(stamp_ns).T_world_vehicle.translation().head<2>();
    const Eigen::Vector2d shifted = now + (xy - T->translation().head<2>());
    dead_reckoning_.resetPosition(shifted.x(), shifted.y());
    aligned_ = true;
  }
}

}  // namespace vog::app
