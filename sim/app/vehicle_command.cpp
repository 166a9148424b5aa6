#include "vehicle_command.hpp"

#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <thread>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "vog/sim/scene.hpp"
#include "vog/sim/world.hpp"
#include "vog/vehicle/control.hpp"
#include "vog/vehicle/endpoints.hpp"
#include "vog/vehicle/sim_vehicle.hpp"

namespace vogsim {

VehicleCommand::VehicleCommand(CLI::App& app) {
  sub_ =
      app.add_subcommand("vehicle",
                         "Run the simulated vehicle in paced simulated time behind mock devices (ptys, CAN stand-in, "
                         "UDP sonar, backseat TCP)");
  sub_->add_option("--scene", scene_file_, "Scene YAML file")->required()->check(CLI::ExistingFile);
  sub_->add_option("--seed", seed_, "Random seed");
  sub_->add_option("--speedup", speedup_, "Simulated seconds per wall second")->check(CLI::Range(0.01, 1000.0));
  sub_->add_option("--endpoints", endpoints_file_, "Endpoints file to write (default RUN_DIR/endpoints.yaml)");
  sub_->add_option("--run-dir", run_dir_, "Folder for the pty links and the CAN socket (default: a new temp folder)");
  sub_->add_option("--control", control_socket_, "Unix socket accepting control commands (besides stdin)");
  sub_->add_option("--backseat-port", backseat_port_, "Backseat TCP port on 127.0.0.1 (0 = any free)")
      ->check(CLI::Range(0, 65535));
  sub_->add_option("--sonar-port", sonar_port_,
                   "Sonar kind fragments: UDP port on 127.0.0.1 the sonar frames go to (0 = sonar off)")
      ->check(CLI::Range(0, 65535));
  sub_->add_option("--sonar-kind", sonar_kind_,
                   "fragments: frames as fragment datagrams to --sonar-port; aris: a mock ARIS sonar on the ARIS live "
                   "protocol (command TCP port, Availability beacon, frames to the receiver its client sets)")
      ->check(CLI::IsMember({"fragments", "aris"}));
  sub_->add_option("--aris-command-port", aris_command_port_,
                   "Sonar kind aris: command TCP port on 127.0.0.1 (0 = any free; a real ARIS: 56888)")
      ->check(CLI::Range(0, 65535));
  sub_->add_option("--aris-beacon-port", aris_beacon_port_,
                   "Sonar kind aris: UDP port on 127.0.0.1 the Availability beacon goes to (0 = no beacon; a real "
                   "ARIS: 56124)")
      ->check(CLI::Range(0, 65535));
  sub_->add_option("--aris-serial", aris_serial_, "Sonar kind aris: serial number in the beacon");
  sub_->add_option("--duration-s", duration_s_, "Simulated time limit, s (0 = until SIGTERM/SIGINT)")
      ->check(CLI::Range(0.0, 1e7));
  sub_->add_option("--origin-lat", origin_lat_deg_, "Latitude of world (0, 0), deg")->check(CLI::Range(-80.0, 80.0));
  sub_->add_option("--origin-lon", origin_lon_deg_, "Longitude of world (0, 0), deg")->check(CLI::Range(-180.0, 180.0));
  sub_->add_flag("--no-stdin", no_stdin_, "Do not read control commands from stdin");
}

int VehicleCommand::run() {
  // Logs go to stderr: stdout carries the replies to control lines read from stdin.
  spdlog::set_default_logger(spdlog::stderr_color_mt("vogsim"));
  // SIGINT/SIGTERM are blocked in every thread (the mask is inherited) and taken by sigtimedwait
  // on this one, so shutdown is an ordinary code path.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  auto scene = vog::sim::loadScene(scene_file_);
  if (!scene) {
    spdlog::error("{}", scene.error().message);
    return 2;
  }
  auto world = vog::sim::World::create(*scene);
  if (!world) {
    spdlog::error("{}", world.error().message);
    return 2;
  }

  bool own_run_dir = false;
  std::filesystem::path run_dir = run_dir_;
  if (run_dir.empty()) {
    std::string tmpl = (std::filesystem::temp_directory_path() / "vogsim-XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) {
      spdlog::error("cannot create a run folder from {}", tmpl);
      return 2;
    }
    run_dir = tmpl;
    own_run_dir = true;
  }
  const std::filesystem::path endpoints_file =
      endpoints_file_.empty() ? run_dir / "endpoints.yaml" : std::filesystem::path(endpoints_file_);

  vog::vehicle::SimVehicleConfig config;
  config.seed = seed_;
  config.speedup = speedup_;
  config.duration_s = duration_s_;
  config.run_dir = run_dir;
  config.backseat_port = static_cast<std::uint16_t>(backseat_port_);
  config.sonar_port = static_cast<std::uint16_t>(sonar_port_);
  config.sonar_kind = *vog::vehicle::parseSonarKind(sonar_kind_);  // checked by the option
  config.aris_command_port = static_cast<std::uint16_t>(aris_command_port_);
  config.aris_beacon_port = static_cast<std::uint16_t>(aris_beacon_port_);
  config.aris_serial_number = aris_serial_;
  config.origin_latitude_deg = origin_lat_deg_;
  config.origin_longitude_deg = origin_lon_deg_;
  auto vehicle = vog::vehicle::SimVehicle::create(**world, config, [](const std::string& e) { spdlog::info("{}", e); });
  if (!vehicle) {
    spdlog::error("{}", vehicle.error().message);
    if (own_run_dir) std::filesystem::remove_all(run_dir);
    return 2;
  }
  vog::vehicle::SimVehicle& v = **vehicle;

  std::unique_ptr<vog::vehicle::ControlServer> control_server;
  auto handle_line = [&v](const std::string& line) -> std::string {
    auto reply = v.control(line);
    return reply ? *reply : "error: " + reply.error().message;
  };
  if (!control_socket_.empty()) {
    auto cs = vog::vehicle::ControlServer::create(control_socket_, handle_line);
    if (!cs) {
      spdlog::error("{}", cs.error().message);
      return 2;
    }
    control_server = std::move(cs).value();
  }

  if (vog::Status st = v.start(); !st) {
    spdlog::error("{}", st.error().message);
    return 2;
  }
  vog::vehicle::VehicleEndpoints endpoints = v.endpoints();
  endpoints.scene_file = std::filesystem::absolute(scene_file_).string();
  endpoints.control_socket = control_socket_.empty() ? "" : std::filesystem::absolute(control_socket_).string();
  if (vog::Status st = vog::vehicle::writeEndpointsFile(endpoints_file, endpoints); !st) {
    spdlog::error("{}", st.error().message);
    v.stop();
    return 2;
  }
  const std::string sonar_text = endpoints.sonar_kind == vog::vehicle::SonarKind::kAris
                                     ? "sonar aris serial " + std::to_string(endpoints.sonar_serial_number) +
                                           " commands tcp 127.0.0.1:" + std::to_string(endpoints.sonar_command_port) +
                                           " beacon udp 127.0.0.1:" + std::to_string(endpoints.sonar_beacon_port)
                                     : "sonar udp 127.0.0.1:" + std::to_string(endpoints.sonar_port);
  spdlog::info(
      "vehicle running: scene {} seed {} speedup {}; dvl {} depth {} imu {} {} backseat tcp 127.0.0.1:{}; "
      "endpoints {}",
      endpoints.scene_name, seed_, speedup_, endpoints.dvl_device, endpoints.depth_device, endpoints.imu_unix_seqpacket,
      sonar_text, endpoints.backseat_port, endpoints_file.string());

  // Control lines on stdin, replies on stdout.
  std::atomic<bool> quit{false};
  std::thread stdin_reader;
  if (!no_stdin_) {
    stdin_reader = std::thread([&] {
      std::string line;
      while (!quit.load()) {
        pollfd p{STDIN_FILENO, POLLIN, 0};
        const int n = ::poll(&p, 1, 100);
        if (n <= 0) continue;
        char buf[256];
        const ssize_t got = ::read(STDIN_FILENO, buf, sizeof buf);
        if (got <= 0) return;  // EOF or error: no more commands from stdin
        for (ssize_t i = 0; i < got; ++i) {
          if (buf[i] != '\n') {
            if (line.size() < 1024) line.push_back(buf[i]);
            continue;
          }
          const std::string reply = handle_line(line);
          line.clear();
          std::fprintf(stdout, "%s\n", reply.c_str());
          std::fflush(stdout);
        }
      }
    });
  }

  int exit_code = 0;
  const timespec tick{0, 100'000'000};
  for (;;) {
    const int sig = sigtimedwait(&signals, nullptr, &tick);
    if (sig == SIGINT || sig == SIGTERM) {
      spdlog::info("{} received, stopping", sig == SIGINT ? "SIGINT" : "SIGTERM");
      break;
    }
    if (v.waitFinished(std::chrono::milliseconds(0))) {
      spdlog::info("simulated duration reached");
      break;
    }
  }
  const auto t_stop = std::chrono::steady_clock::now();
  v.stop();
  quit = true;
  if (stdin_reader.joinable()) stdin_reader.join();
  control_server.reset();
  const vog::vehicle::VehicleSnapshot s = v.snapshot();
  vehicle->reset();  // closes every device (pty links and the CAN socket removed)
  std::error_code ec;
  std::filesystem::remove(endpoints_file, ec);
  if (own_run_dir) std::filesystem::remove_all(run_dir, ec);
  spdlog::info(
      "stopped in {:.0f} ms: {:.1f} s simulated, {} scans, {} dvl, {} imu, {} depth samples, {} of {} "
      "commands accepted, max lag {:.1f} ms, {:.2f} ms per ping step",
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_stop).count(),
      static_cast<double>(s.stamp_ns) * 1e-9, s.scans, s.dvl_sent, s.imu_sent, s.depth_sent, s.commands_accepted,
      s.commands_accepted + s.commands_rejected, s.max_lag_ms, s.ping_step_ms_mean);
  return exit_code;
}

}  // namespace vogsim
