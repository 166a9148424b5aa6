// The simulated vehicle in-process at speedup 10 on the pilings scene, read by the real drivers
// exactly as vogd reads real devices: SerialTransport + PD0 / Digiquartz codecs on the ptys,
// CanTransport + IMU codec on the SOCK_SEQPACKET stand-in, UdpReceiver + fragment reassembly +
// range extraction for the sonar, TcpClient + BackseatCodec + AckTracker for the backseat.
// Receivers stamp data at reception with the simulation's clock (the newest step's stamp), as a
// daemon following the simulator's time does; the alternative, the endpoints' steady-clock time
// base, multiplies every scheduling delay of this shared machine by the speed-up.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <memory>
#include <map>
#include <optional>
#include <numbers>

#include "pump.hpp"
#include "test_support.hpp"
#include "vog/backseat/backseat.hpp"
#include "vog/codec/stream_decoder.hpp"
#include "vog/depth/digiquartz.hpp"
#include "vog/dvl/pd0.hpp"
#include "vog/imu/imu_can.hpp"
#include "vog/io/can.hpp"
#include "vog/io/serial.hpp"
#include "vog/io/tcp_client.hpp"
#include "vog/io/udp.hpp"
#include "vog/nav/dead_reckoning.hpp"
#include "vog/sim/scene.hpp"
#include "vog/sim/world.hpp"
#include "vog/sonar/range_extraction.hpp"
#include "vog/sonar/sonar_udp.hpp"
#include "vog/backseat/local_tangent_plane.hpp"
#include "vog/vehicle/sim_vehicle.hpp"

namespace vog::vehicle {
namespace {

using backseat::GeoPoint;
using backseat::LocalTangentPlane;

using namespace std::chrono_literals;

std::unique_ptr<sim::World> loadPilings() {
  auto scene = sim::loadScene(test::sourceDir() / "config/scenes/pilings.yaml");
  if (!scene) return nullptr;
  auto world = sim::World::create(*scene);
  return world ? std::move(world).value() : nullptr;
}

// Everything a daemon would run against the vehicle's endpoints.
struct Bench {
  struct DecodedDepth {
    std::int64_t stamp_ns;
    double depth_m;
  };

  explicit Bench(double speedup, io::ReconnectConfig reconnect_config = {}) : dir("vog-vehicle") {
    world = loadPilings();
    // The sonar receiver binds first so the vehicle can be told its port.
    io::UdpReceiverConfig uc;
    sonar_rx =
        std::make_unique<io::UdpReceiver>(ioc, uc, clock(), [this](std::span<const std::uint8_t> d, std::int64_t) {
          auto r = sonar::SonarUdpCodec{}.decode(d);
          if (!r.isFrame()) return;
          if (auto frame = reassembler.add(r.frame())) compareFrame(*frame);
        });
    nav::DeadReckoningConfig nc;
    nc.imu_max_gap_s = 0.5;  // scheduling jitter on a loaded machine is multiplied by the speedup
    nc.imu_timeout_s = 0.5;
    dr.emplace(nc);
    config.speedup = speedup;
    config.run_dir = dir.path();
    config.backseat_port = 0;
    reconnect = reconnect_config;
  }

  // Range extraction (default config) of a received frame against the simulator's own scan.
  void compareFrame(const sonar::SonarFrame& f) {
    ++frames_n;
    auto truth_scan = vehicle ? vehicle->scanOfFrame(f.frame_index) : std::nullopt;
    if (!truth_scan) return;
    auto extracted = sonar::extractRanges(f, sonar::RangeExtractionConfig{});
    if (!extracted) {
      ++extraction_errors;
      return;
    }
    for (std::size_t i = 0; i < truth_scan->range_m.size(); ++i) {
      const double a = truth_scan->range_m[i], x = extracted->range_m[i];
      ++beams;
      if (std::isfinite(a) == std::isfinite(x)) ++presence_agree;
      if (std::isfinite(a) && std::isfinite(x)) {
        range_errors_m.push_back(std::abs(a - x));
        if (std::abs(a - x) <= f.sampleLength_m() * 1.5) ++within_1_5_samples;
      }
    }
  }

  io::StampClock clock() {
    return [this] { return vehicle ? vehicle->simStampNs() : 0; };
  }

  ::testing::AssertionResult start() {
    if (!world) return ::testing::AssertionFailure() << "pilings scene did not load";
    if (Status st = sonar_rx->start(); !st) return ::testing::AssertionFailure() << st.error().message;
    if (!test::pumpUntil(ioc, [&] { return sonar_rx->localPort() != 0; }))
      return ::testing::AssertionFailure() << "udp bind";
    config.sonar_port = sonar_rx->localPort();
    auto v = SimVehicle::create(*world, config,
                                [](const std::string& e) { std::fprintf(stderr, "vehicle: %s\n", e.c_str()); });
    if (!v) return ::testing::AssertionFailure() << v.error().message;
    vehicle = std::move(v).value();
    if (Status st = vehicle->start(); !st) return ::testing::AssertionFailure() << st.error().message;
    endpoints = vehicle->endpoints();
    ltp.emplace(*LocalTangentPlane::create({endpoints.origin_latitude_deg, endpoints.origin_longitude_deg}));

    io::SerialConfig dc;
    dc.device_path = endpoints.dvl_device;
    dc.baud = endpoints.dvl_baud;
    dc.reconnect = reconnect;
    dvl_port = std::make_unique<io::SerialTransport>(ioc, dc, clock(),
                                                     [this](std::span<const std::uint8_t> b, std::int64_t t) {
                                                       pd0.feed(b);
                                                       while (auto e = pd0.next()) {
                                                         // The ensemble's own real-time clock (10 ms resolution; the
                                                         // simulated DVL pings every 200 ms, so it is exact) rather
                                                         // than the reception time: the integration interval of dead
                                                         // reckoning then does not depend on this machine's scheduling.
                                                         auto rtc = dvl::clockToUnixNs(e->variable.clock);
                                                         e->stamp_ns = rtc ? *rtc - endpoints.epoch_unix_ns : t;
                                                         ++dvl_n;
                                                         last_dvl_stamp_ns = e->stamp_ns;
                                                         if (dr->addDvl(*e).ok()) ++dvl_used;
                                                       }
                                                     });
    io::SerialConfig qc;
    qc.device_path = endpoints.depth_device;
    qc.baud = endpoints.depth_baud;
    qc.reconnect = reconnect;
    depth_port = std::make_unique<io::SerialTransport>(
        ioc, qc, clock(), [this](std::span<const std::uint8_t> b, std::int64_t t) {
          dq.feed(b);
          while (auto m = dq.next()) {
            depth::DepthConversionConfig conv;
            conv.units_code = endpoints.depth_units_code;
            conv.latitude_deg = endpoints.depth_latitude_deg;
            conv.atmospheric_pressure_pa = endpoints.depth_atmospheric_pressure_pa;
            conv.reading_is_absolute = endpoints.depth_reading_is_absolute;
            auto s = depth::toDepthSample(*m, conv, t);
            if (!s) continue;
            depths.push_back({t, s->depth_m});
            (void)dr->addDepth(*s);
          }
        });
    io::CanConfig cc;
    cc.unix_seqpacket = endpoints.imu_unix_seqpacket;
    cc.reconnect = reconnect;
    imu_port = std::make_unique<io::CanTransport>(ioc, cc, clock(), [this](const can_frame& f, std::int64_t t) {
      imu_dec.feed(imu::canFramesToBytes(std::span<const can_frame>(&f, 1)));
      while (auto s = imu_dec.next()) {
        s->stamp_ns = t;
        ++imu_n;
        (void)dr->addImu(*s);
      }
    });
    io::TcpClientConfig tc;
    tc.port = endpoints.backseat_port;
    tc.reconnect = reconnect;
    backseat_port =
        std::make_unique<io::TcpClient>(ioc, tc, clock(), [this](std::span<const std::uint8_t> b, std::int64_t t) {
          bs.feed(b);
          while (auto s = bs.next()) {
            if (auto* nvg = std::get_if<backseat::NavSentence>(&*s)) {
              nvg->stamp_ns = t;
              last_nvg = *nvg;
              ++nvg_n;
            } else if (auto* ack = std::get_if<backseat::AckSentence>(&*s)) {
              acks.push_back(*ack);
              (void)tracker.onAck(*ack);
            }
          }
        });
    for (Status st : {dvl_port->start(), depth_port->start(), imu_port->start(), backseat_port->start()}) {
      if (!st) return ::testing::AssertionFailure() << st.error().message;
    }
    if (!test::pumpUntil(
            ioc,
            [&] {
              return depth_port->health().state == io::LinkState::kConnected && imu_n > 0 && dvl_n > 0 && nvg_n > 0;
            },
            5000ms))
      return ::testing::AssertionFailure()
             << "devices did not come up: dvl " << dvl_n << " imu " << imu_n << " nvg " << nvg_n;
    const std::string p4 = depth::encodeCommand(1, 0, "P4");  // continuous readings
    if (Status st = depth_port->write(std::vector<std::uint8_t>(p4.begin(), p4.end())); !st)
      return ::testing::AssertionFailure() << st.error().message;
    return ::testing::AssertionSuccess();
  }

  std::int64_t now() { return vehicle->simStampNs(); }

  // Truth at a receiver stamp, once the simulation has stepped past it (reception stamps can run
  // a step ahead of the newest simulated state).
  Result<sim::VehicleState> truthAt(std::int64_t stamp_ns) {
    (void)test::pumpUntil(
        ioc, [&] { return vehicle->simStampNs() >= stamp_ns; }, 1000ms);
    return vehicle->truthAt(stamp_ns);
  }

  bool runUntilSim(std::int64_t stamp_ns, std::chrono::milliseconds timeout = 10s) {
    return test::pumpUntil(
        ioc, [&] { return now() >= stamp_ns; }, timeout);
  }

  // Sends $BPGHP to the world point (x, y, z) through the tracker; returns the sentence's id.
  std::uint32_t goTo(const Eigen::Vector3d& xyz, std::optional<double> heading_deg = std::nullopt) {
    backseat::WaypointCommand w;
    w.id = ++next_id;
    const GeoPoint g = ltp->toGeo(xyz.head<2>());
    w.latitude_deg = g.latitude_deg;
    w.longitude_deg = g.longitude_deg;
    w.depth_m = -xyz.z();
    w.speed_mps = 0.25;
    w.heading_deg = heading_deg;
    // What the vehicle receives: the position at the sentence's resolution (1e-6' = 2 mm).
    const std::string text = backseat::encodeBackseat(w);
    auto r = backseat::BackseatCodec{}.decode(
        std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
    EXPECT_TRUE(r.isFrame());
    if (r.isFrame()) {
      const auto& q = std::get<backseat::WaypointCommand>(r.frame());
      const Eigen::Vector2d xy = ltp->toLocal({q.latitude_deg, q.longitude_deg});
      expected[w.id] = Eigen::Vector3d(xy.x(), xy.y(), -q.depth_m);
      EXPECT_LT((expected[w.id] - xyz).norm(), 0.005);
    }
    auto line = tracker.send(w, now());
    EXPECT_TRUE(line.ok());
    if (line.ok()) {
      EXPECT_TRUE(backseat_port->write(std::vector<std::uint8_t>(line->begin(), line->end())).ok());
    }
    return w.id;
  }

  std::optional<backseat::AckSentence> ackOf(std::uint32_t id) const {
    for (const auto& a : acks) {
      if (a.command_id == id) return a;
    }
    return std::nullopt;
  }

  test::TempDir dir;
  std::unique_ptr<sim::World> world;
  SimVehicleConfig config;
  io::ReconnectConfig reconnect;
  asio::io_context ioc;
  std::unique_ptr<SimVehicle> vehicle;
  VehicleEndpoints endpoints;
  std::optional<LocalTangentPlane> ltp;
  std::optional<nav::DeadReckoning> dr;

  codec::StreamDecoder<dvl::Pd0Codec> pd0;
  codec::StreamDecoder<depth::DigiquartzCodec> dq;
  codec::StreamDecoder<imu::ImuCanCodec> imu_dec;
  codec::StreamDecoder<backseat::BackseatCodec> bs;
  sonar::FrameReassembler reassembler{8};
  backseat::AckTracker tracker;
  std::unique_ptr<io::UdpReceiver> sonar_rx;
  std::unique_ptr<io::SerialTransport> dvl_port, depth_port;
  std::unique_ptr<io::CanTransport> imu_port;
  std::unique_ptr<io::TcpClient> backseat_port;

  std::uint64_t dvl_n = 0, dvl_used = 0, imu_n = 0, nvg_n = 0;
  std::int64_t last_dvl_stamp_ns = 0;
  std::vector<DecodedDepth> depths;
  std::uint64_t frames_n = 0, extraction_errors = 0, beams = 0, presence_agree = 0, within_1_5_samples = 0;
  std::vector<double> range_errors_m;
  std::vector<backseat::AckSentence> acks;
  std::optional<backseat::NavSentence> last_nvg;
  std::uint32_t next_id = 0;
  std::map<std::uint32_t, Eigen::Vector3d> expected;  // command id -> target as the vehicle decodes it
};

// ~30 s simulated at speedup 5: two go-to commands over the backseat, dead reckoning from the
// decoded DVL + IMU + depth against the truth, depth and sonar decoding against the simulator.
TEST(SimVehicleTest, RealDriversDecodeEveryDeviceAndDeadReckoningTracksTruth) {
  Bench b(5.0);
  ASSERT_TRUE(b.start());
  // Dead reckoning starts at the true start position (as vogd's mission starts at a known pose).
  ASSERT_TRUE(test::pumpUntil(
      b.ioc, [&] { return b.dr->solution(b.now()).initialized; }, 5000ms));
  b.dr->resetPosition(b.endpoints.start_xyz_world.x(), b.endpoints.start_xyz_world.y());

  const Eigen::Vector3d first(-4.0, -1.0, -2.0), second(-1.5, -1.0, -2.0);
  const std::uint32_t id1 = b.goTo(first);
  ASSERT_TRUE(test::pumpUntil(b.ioc, [&] { return b.ackOf(id1).has_value(); }));
  EXPECT_EQ(b.ackOf(id1)->status, backseat::AckStatus::kAccepted) << b.ackOf(id1)->reason;
  EXPECT_EQ(b.tracker.pendingCount(), 0u);

  double max_dr_error_m = 0.0;
  std::uint64_t compared = 0, last_dvl_seen = 0;
  bool sent_second = false;
  std::uint32_t id2 = 0;
  const std::int64_t end_ns = 30'000'000'000;
  while (b.now() < end_ns) {
    ASSERT_TRUE(test::pumpUntil(
        b.ioc, [&] { return b.dvl_n > last_dvl_seen || b.now() >= end_ns; }, 3000ms));
    last_dvl_seen = b.dvl_n;
    const nav::NavSolution sol = b.dr->solution(b.last_dvl_stamp_ns);
    auto truth = b.truthAt(b.last_dvl_stamp_ns);
    ASSERT_TRUE(truth.ok()) << truth.error().message;
    const double e = (sol.T_world_vehicle.translation().head<2>() - truth->xyz_world.head<2>()).norm();
    max_dr_error_m = std::max(max_dr_error_m, e);
    ++compared;
    if (!sent_second && (b.vehicle->snapshot().truth.xyz_world - b.expected[id1]).norm() < 0.02) {
      id2 = b.goTo(second, 30.0);  // and face 30 deg east of north on the way
      sent_second = true;
    }
  }
  ASSERT_TRUE(sent_second) << "the first target was never reached";
  ASSERT_TRUE(b.ackOf(id2).has_value());
  EXPECT_EQ(b.ackOf(id2)->status, backseat::AckStatus::kAccepted);

  const VehicleSnapshot snap = b.vehicle->snapshot();
  // The vehicle steers on its navigation estimate (odometry drift is millimetres here), and holds
  // the commanded heading: 30 deg east of north is a world yaw of 60 deg.
  EXPECT_LT((snap.truth.xyz_world - b.expected[id2]).norm(), 0.02);
  EXPECT_NEAR(geometry::wrapAngle(snap.truth.yaw_rad - 60.0 * std::numbers::pi / 180.0), 0.0, 0.02);
  EXPECT_EQ(snap.commands_accepted, 2u);
  // The vehicle's own navigation as decoded from $BFNVG (2 mm resolution; odometry drift is millimetres).
  ASSERT_TRUE(b.last_nvg.has_value());
  const Eigen::Vector2d nvg_xy = b.ltp->toLocal({b.last_nvg->latitude_deg, b.last_nvg->longitude_deg});
  EXPECT_LT((nvg_xy - second.head<2>()).norm(), 0.05);
  EXPECT_NEAR(b.last_nvg->depth_m, 2.0, 0.05);

  // Dead reckoning: DVL at 5 Hz (mm/s on the wire) stamped by its clock, IMU attitude (1e-4 rad)
  // stamped at reception, trapezoidal integration; the vehicle starts and stops abruptly, which
  // the trapezoid misses by at most v * dt / 2 = 2.5 cm per transition.
  EXPECT_GT(compared, 100u);
  EXPECT_GT(b.dvl_used, 100u);
  EXPECT_LT(max_dr_error_m, 0.15) << "max dead-reckoning error over 30 s";
  const nav::NavSolution final_sol = b.dr->solution(b.last_dvl_stamp_ns);
  EXPECT_LT((final_sol.T_world_vehicle.translation().head<2>() - snap.truth.xyz_world.head<2>()).norm(), 0.15);
  EXPECT_NEAR(final_sol.T_world_vehicle.translation().z(), second.z(), 0.05);
  ::testing::Test::RecordProperty("max_dead_reckoning_error_mm", static_cast<int>(max_dr_error_m * 1000.0));

  // Depth: every decoded reading equals a simulated reading to the wire resolution (1e-4 psi =
  // 0.07 mm; readings differ by ~1 cm of sensor noise) sent no later than its reception and at
  // most 1 s before it, and lies within 0.15 m of the true depth at its reception.
  ASSERT_GT(b.depths.size(), 200u);
  std::size_t exact = 0, checked = 0;
  for (const auto& d : b.depths) {
    auto truth = b.truthAt(d.stamp_ns);
    if (!truth) continue;  // older than the kept history
    ++checked;
    EXPECT_NEAR(d.depth_m, -truth->xyz_world.z(), 0.15);
    for (const StampedDepth& s : b.vehicle->depthSamples(d.stamp_ns - 1'000'000'000, d.stamp_ns)) {
      if (std::abs(s.depth_m - d.depth_m) < 1e-3) {
        ++exact;
        break;
      }
    }
  }
  EXPECT_GT(checked, 200u);
  EXPECT_GT(static_cast<double>(exact), 0.95 * static_cast<double>(checked));

  // Sonar: frames over UDP, reassembled, range extraction (default config) vs the simulator's scan.
  EXPECT_GT(b.frames_n, 100u);  // 5 Hz over ~30 s
  EXPECT_EQ(b.extraction_errors, 0u);
  const std::size_t both = b.range_errors_m.size();
  ASSERT_GT(both, 1000u);
  std::vector<double> errors = b.range_errors_m;
  std::sort(errors.begin(), errors.end());
  const double median = errors[both / 2], p95 = errors[both * 95 / 100];
  const double presence = static_cast<double>(b.presence_agree) / static_cast<double>(b.beams);
  const double within = static_cast<double>(b.within_1_5_samples) / static_cast<double>(both);
  EXPECT_GT(presence, 0.97);
  EXPECT_GT(within, 0.95);
  EXPECT_LT(median, 0.03);
  ::testing::Test::RecordProperty("sonar_beams_with_both_returns", static_cast<int>(both));
  ::testing::Test::RecordProperty("sonar_median_error_mm", static_cast<int>(std::lround(median * 1000.0)));
  ::testing::Test::RecordProperty("sonar_p95_error_mm", static_cast<int>(std::lround(p95 * 1000.0)));
  ::testing::Test::RecordProperty("sonar_presence_agree_permille", static_cast<int>(std::lround(presence * 1000.0)));
  ::testing::Test::RecordProperty("sonar_within_1_5_samples_permille", static_cast<int>(std::lround(within * 1000.0)));
}

// A new command replaces the current target at once; an impossible one is refused with a reason.
TEST(SimVehicleTest, NewCommandReplacesTargetAndBadTargetIsRefused) {
  Bench b(20.0);
  ASSERT_TRUE(b.start());
  const Eigen::Vector3d north(-4.0, 1.0, -2.0), south(-4.0, -1.0, -2.0);
  const std::uint32_t id1 = b.goTo(north);
  ASSERT_TRUE(test::pumpUntil(b.ioc, [&] { return b.ackOf(id1).has_value(); }));
  ASSERT_TRUE(b.runUntilSim(b.now() + 2'000'000'000));
  const double y_before = b.vehicle->snapshot().truth.xyz_world.y();
  EXPECT_GT(y_before, 0.05);  // on its way north
  const std::uint32_t id2 = b.goTo(south);
  ASSERT_TRUE(test::pumpUntil(b.ioc, [&] { return b.ackOf(id2).has_value(); }));
  EXPECT_EQ(b.ackOf(id2)->status, backseat::AckStatus::kAccepted);
  // Far outside the scene's box (and the 5 m margin): refused, the vehicle keeps its target.
  const std::uint32_t id3 = b.goTo(Eigen::Vector3d(100.0, 0.0, -2.0));
  ASSERT_TRUE(test::pumpUntil(b.ioc, [&] { return b.ackOf(id3).has_value(); }));
  EXPECT_EQ(b.ackOf(id3)->status, backseat::AckStatus::kFailed);
  EXPECT_NE(b.ackOf(id3)->reason.find("outside the operating area"), std::string::npos) << b.ackOf(id3)->reason;
  double max_y = y_before;
  ASSERT_TRUE(test::pumpUntil(
      b.ioc,
      [&] {
        const auto s = b.vehicle->snapshot();
        max_y = std::max(max_y, s.truth.xyz_world.y());
        return (s.truth.xyz_world - b.expected[id2]).norm() < 0.02;
      },
      5000ms))
      << "did not reach the replacing target";
  // Never went on to the replaced target (queued semantics would have reached y = 0.93 first).
  EXPECT_LT(max_y, b.expected[id1].y() - 0.2);
  const VehicleSnapshot s = b.vehicle->snapshot();
  EXPECT_EQ(s.commands_accepted, 2u);
  EXPECT_EQ(s.commands_rejected, 1u);
}

// Faults injected through the control interface are survived by the real transports: garbage on
// the DVL line is skipped by the decoder, an unplugged DVL pty / IMU socket / backseat server is
// reopened by the transport's reconnect and decoding resumes.
TEST(SimVehicleTest, InjectedGarbageAndUnplugsAreSurvived) {
  io::ReconnectConfig fast;
  fast.initial_delay_ms = 20;
  fast.max_delay_ms = 100;
  Bench b(10.0, fast);
  ASSERT_TRUE(b.start());

  auto ok = b.vehicle->control("fault dvl garbage 2");
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  ASSERT_TRUE(b.runUntilSim(b.now() + 3'000'000'000));
  EXPECT_GT(b.pd0.stats().garbage_bytes, 0u);
  std::uint64_t before = b.dvl_n;
  ASSERT_TRUE(test::pumpUntil(b.ioc, [&] { return b.dvl_n >= before + 5; }));  // decoding goes on

  EXPECT_FALSE(b.vehicle->control("fault dvl sparks 2").ok());
  for (const char* line : {"unplug dvl 3", "unplug imu 3", "unplug backseat 3"}) {
    auto r = b.vehicle->control(line);
    ASSERT_TRUE(r.ok()) << r.error().message;
  }
  ASSERT_TRUE(test::pumpUntil(b.ioc, [&] {
    return b.dvl_port->health().state != io::LinkState::kConnected &&
           b.imu_port->health().state != io::LinkState::kConnected &&
           b.backseat_port->health().state != io::LinkState::kConnected;
  })) << "the unplugs were not seen";
  ASSERT_TRUE(test::pumpUntil(
      b.ioc,
      [&] {
        return b.dvl_port->health().connects >= 2 && b.imu_port->health().connects >= 2 &&
               b.backseat_port->health().connects >= 2;
      },
      5000ms))
      << "the transports did not reconnect";
  before = b.dvl_n;
  const std::uint64_t imu_before = b.imu_n, nvg_before = b.nvg_n;
  ASSERT_TRUE(test::pumpUntil(b.ioc, [&] {
    return b.dvl_n >= before + 5 && b.imu_n >= imu_before + 50 && b.nvg_n >= nvg_before + 5;
  })) << "decoding did not resume";
  // And the backseat link still carries commands.
  const std::uint32_t id = b.goTo(Eigen::Vector3d(-4.5, 0.0, -1.5));
  ASSERT_TRUE(test::pumpUntil(b.ioc, [&] { return b.ackOf(id).has_value(); }));
  EXPECT_EQ(b.ackOf(id)->status, backseat::AckStatus::kAccepted);
}

}  // namespace
}  // namespace vog::vehicle
