#pragma once
// `vogsim vehicle`: the simulated vehicle behind mock devices as a separate process
// (sim/vehicle, sim/README.md "vogsim vehicle").

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>

namespace vogsim {

// Registers the subcommand and its options on construction; run() after parsing when parsed().
class VehicleCommand {
 public:
  explicit VehicleCommand(CLI::App& app);
  bool parsed() const { return sub_->parsed(); }
  int run();

 private:
  CLI::App* sub_;
  std::string scene_file_;
  std::uint64_t seed_ = 1;
  double speedup_ = 1.0;
  std::string endpoints_file_;
  std::string run_dir_;
  std::string control_socket_;
  int backseat_port_ = 29500;
  int sonar_port_ = 52102;
  std::string sonar_kind_ = "fragments";
  int aris_command_port_ = 0;
  int aris_beacon_port_ = 0;
  std::uint32_t aris_serial_ = 1234;
  double duration_s_ = 0.0;
  double origin_lat_deg_ = 42.0;
  double origin_lon_deg_ = -71.0;
  bool no_stdin_ = false;
};

}  // namespace vogsim
