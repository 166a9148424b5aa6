// vog-bench vehicle: `vogsim vehicle` in-process at several speed-ups on a shipped scene, read over
// the real daemon path: sonar fragments over UDP -> reassembly -> range extraction (default config),
// compared beam by beam with the simulator's own scan; the vehicle driven along the y = -1 lane by
// $BPGHP commands over the backseat TCP link. Reports per speed-up: worst lateness of a step
// behind its wall-clock due time, mean wall time of a step that renders and sends a sonar frame,
// frames sent / completed, and the range agreement. Real time holds while max lag stays small.
#include "bench_cli.hpp"
#include "bench_registry.hpp"

#include <asio.hpp>
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "vog/backseat/backseat.hpp"
#include "vog/io/tcp_client.hpp"
#include "vog/io/udp.hpp"
#include "vog/sim/scene.hpp"
#include "vog/sim/world.hpp"
#include "vog/sonar/range_extraction.hpp"
#include "vog/sonar/sonar_udp.hpp"
#include "vog/backseat/local_tangent_plane.hpp"
#include "vog/vehicle/sim_vehicle.hpp"

VOG_BENCH_COMMAND(vehicle, "vogsim vehicle: real-time pacing and sonar range agreement over UDP at several speed-ups") {
  std::string scene_file = "config/scenes/pilings.yaml";
  std::vector<double> speedups = {5.0, 10.0, 20.0, 50.0};
  double sim_seconds = 40.0;
  std::uint64_t seed = 1;
  bool json = false;
  CLI::App app{"vog-bench vehicle"};
  app.add_option("--scene", scene_file, "scene YAML file (the lane y = -1, z = -2 must be free)");
  app.add_option("--speedups", speedups, "speed-ups to run")->check(CLI::Range(0.1, 1000.0));
  app.add_option("--sim-seconds", sim_seconds, "simulated seconds per speed-up")->check(CLI::Range(1.0, 3600.0));
  app.add_option("--seed", seed, "simulation seed");
  app.add_flag("--json", json, "print JSON (the only output format)");
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;
  auto scene = vog::sim::loadScene(scene_file);
  if (!scene) {
    std::cerr << "vehicle bench: " << scene.error().message << "\n";
    return 1;
  }
  auto world = vog::sim::World::create(*scene);
  if (!world) {
    std::cerr << "vehicle bench: " << world.error().message << "\n";
    return 1;
  }
  const std::filesystem::path run_dir =
      std::filesystem::temp_directory_path() / ("vog-bench-vehicle-" + std::to_string(::getpid()));
  std::filesystem::create_directories(run_dir);

  vog::bench::JsonObject out;
  out.add("scene", scene->name);
  out.add("sim_seconds", sim_seconds);
  for (const double speedup : speedups) {
    asio::io_context ioc;
    vog::sonar::FrameReassembler reassembler(8);
    std::unique_ptr<vog::vehicle::SimVehicle> vehicle;
    std::vector<double> errors;
    std::uint64_t beams = 0, presence_agree = 0, frames = 0;
    vog::io::UdpReceiver rx(ioc, vog::io::UdpReceiverConfig{}, vog::io::steadyStampClock(),
                            [&](std::span<const std::uint8_t> d, std::int64_t) {
                              auto r = vog::sonar::SonarUdpCodec{}.decode(d);
                              if (!r.isFrame()) return;
                              auto f = reassembler.add(r.frame());
                              if (!f || !vehicle) return;
                              ++frames;
                              auto truth = vehicle->scanOfFrame(f->frame_index);
                              auto x = vog::sonar::extractRanges(*f, vog::sonar::RangeExtractionConfig{});
                              if (!truth || !x) return;
                              for (std::size_t i = 0; i < truth->range_m.size(); ++i) {
                                const double a = truth->range_m[i], b = x->range_m[i];
                                ++beams;
                                if (std::isfinite(a) == std::isfinite(b)) ++presence_agree;
                                if (std::isfinite(a) && std::isfinite(b)) errors.push_back(std::abs(a - b));
                              }
                            });
    if (!rx.start().ok()) return 1;
    while (rx.localPort() == 0) ioc.run_one_for(std::chrono::milliseconds(5));
    vog::vehicle::SimVehicleConfig config;
    config.seed = seed;
    config.speedup = speedup;
    config.duration_s = sim_seconds;
    config.run_dir = run_dir;
    config.backseat_port = 0;
    config.sonar_port = rx.localPort();
    auto v = vog::vehicle::SimVehicle::create(**world, config);
    if (!v) {
      std::cerr << "vehicle bench: " << v.error().message << "\n";
      return 1;
    }
    vehicle = std::move(v).value();
    const auto ltp =
        *vog::backseat::LocalTangentPlane::create({config.origin_latitude_deg, config.origin_longitude_deg});
    vog::io::TcpClientConfig tc;
    tc.port = vehicle->endpoints().backseat_port;
    vog::io::TcpClient backseat(ioc, tc, vog::io::steadyStampClock(),
                                [](std::span<const std::uint8_t>, std::int64_t) {});
    if (!vehicle->start().ok() || !backseat.start().ok()) return 1;
    // Lane y = -1 at z = -2: to its west end, then east along it (each command replaces the last).
    const std::vector<Eigen::Vector3d> legs = {{-4.0, -1.0, -2.0}, {4.5, -1.0, -2.0}};
    std::size_t next_leg = 0;
    while (!vehicle->waitFinished(std::chrono::milliseconds(0))) {
      ioc.run_for(std::chrono::milliseconds(20));
      const auto snap = vehicle->snapshot();
      // The next leg once the previous command was accepted and its target reached.
      const bool ready = next_leg == 0 || (snap.commands_accepted >= next_leg && !snap.target_xyz_world);
      if (backseat.health().state == vog::io::LinkState::kConnected && next_leg < legs.size() && ready) {
        vog::backseat::WaypointCommand w;
        w.id = static_cast<std::uint32_t>(next_leg + 1);
        const auto g = ltp.toGeo(legs[next_leg].head<2>());
        w.latitude_deg = g.latitude_deg;
        w.longitude_deg = g.longitude_deg;
        w.depth_m = -legs[next_leg].z();
        w.speed_mps = 0.25;
        const std::string line = vog::backseat::encodeBackseat(w);
        if (backseat.write(std::vector<std::uint8_t>(line.begin(), line.end())).ok()) ++next_leg;
      }
    }
    const auto snap = vehicle->snapshot();
    vehicle.reset();
    std::ostringstream key;
    key << "x" << speedup << "_";
    const std::string k = key.str();
    out.add(k + "max_lag_ms", snap.max_lag_ms);
    out.add(k + "ping_step_ms_mean", snap.ping_step_ms_mean);
    out.add(k + "pings", static_cast<std::int64_t>(snap.scans));
    out.add(k + "frames_completed", static_cast<std::int64_t>(frames));
    out.add(k + "frames_dropped", static_cast<std::int64_t>(reassembler.stats().frames_dropped));
    out.add(k + "beams_compared", static_cast<std::int64_t>(beams));
    out.add(k + "presence_agreement",
            beams > 0 ? static_cast<double>(presence_agree) / static_cast<double>(beams) : 0.0);
    out.add(k + "range_error_median_m", errors.empty() ? -1.0 : vog::bench::median(errors));
    out.add(k + "range_error_p95_m", errors.empty() ? -1.0 : vog::bench::percentile(errors, 0.95));
    out.add(k + "range_error_max_m", errors.empty() ? -1.0 : vog::bench::percentile(errors, 1.0));
    out.add(k + "commands_accepted", static_cast<std::int64_t>(snap.commands_accepted));
  }
  std::filesystem::remove_all(run_dir);
  std::cout << out.str() << "\n";
  return 0;
}
