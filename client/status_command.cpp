// `vogctl status`: the daemon's mission state, pose, uncertainty, devices, map and planner.

#include "commands.hpp"
#include "connection_options.hpp"
#include "json_line.hpp"

#include <cmath>
#include <numbers>
#include <iostream>

namespace vog::client {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

int runStatus(const ConnectionOptions& conn, bool json) {
  auto c = conn.open();
  if (!c) return 1;
  auto status = c->status();
  if (!status) {
    std::fprintf(stderr, "vogctl: status: %s\n", status.error().message.c_str());
    return 1;
  }
  const api::StatusReport& s = *status;
  const Eigen::Vector3d t = s.T_world_vehicle.translation();
  const Eigen::Vector3d rpy = geometry::rpyFromRotation(s.T_world_vehicle.linear());
  if (json) {
    JsonLine line;
    line.add("stamp_ns", static_cast<std::int64_t>(s.stamp_ns))
        .add("mission_state", api::toString(s.mission_state))
        .add("planner_state", api::toString(s.planner_state))
        .add("x_m", t.x()).add("y_m", t.y()).add("z_m", t.z())
        .add("roll_rad", rpy.x()).add("pitch_rad", rpy.y()).add("yaw_rad", rpy.z())
        .add("sigma_x_m", s.sigma_xyz_m.x()).add("sigma_y_m", s.sigma_xyz_m.y()).add("sigma_z_m", s.sigma_xyz_m.z())
        .add("sigma_yaw_rad", s.sigma_yaw_rad)
        .add("n_submaps", static_cast<unsigned>(s.n_submaps))
        .add("n_closures", static_cast<unsigned>(s.n_closures))
        .add("map_version", static_cast<std::uint64_t>(s.map_version));
    std::cout << line.str() << '\n';
    for (const auto& d : s.devices) {
      JsonLine dl;
      dl.add("device", d.name).add("state", api::toString(d.state)).add("detail", d.detail)
          .add("last_stamp_ns", static_cast<std::int64_t>(d.last_stamp_ns))
          .add("messages", static_cast<std::uint64_t>(d.messages)).add("errors", static_cast<std::uint64_t>(d.errors));
      std::cout << dl.str() << '\n';
    }
    return 0;
  }
  char buf[256];
  std::cout << "mission   " << api::toString(s.mission_state) << "\nplanner   " << api::toString(s.planner_state)
            << '\n';
  std::snprintf(buf, sizeof buf, "pose      x %.3f  y %.3f  z %.3f m   yaw %.1f deg", t.x(), t.y(), t.z(),
                rpy.z() * kRadToDeg);
  std::cout << buf << '\n';
  std::snprintf(buf, sizeof buf, "sigma     x %.3f  y %.3f  z %.3f m   yaw %.2f deg", s.sigma_xyz_m.x(),
                s.sigma_xyz_m.y(), s.sigma_xyz_m.z(), s.sigma_yaw_rad * kRadToDeg);
  std::cout << buf << '\n';
  std::cout << "map       " << s.n_submaps << " submaps, " << s.n_closures << " loop closures, version "
            << s.map_version << '\n';
  for (const auto& d : s.devices) {
    std::snprintf(buf, sizeof buf, "device    %-12s %-12s %8llu msgs %6llu errors  %s", d.name.c_str(),
                  api::toString(d.state), static_cast<unsigned long long>(d.messages),
                  static_cast<unsigned long long>(d.errors), d.detail.c_str());
    std::cout << buf << '\n';
  }
  return 0;
}

}  // namespace

void addStatusCommand(CLI::App& app, CommandAction& action) {
  auto* cmd = app.add_subcommand("status", "Mission state, pose, uncertainty, devices, map and planner of vogd");
  struct Options {
    ConnectionOptions conn;
    bool json = false;
  };
  auto opts = std::make_shared<Options>();
  opts->conn.addTo(*cmd);
  cmd->add_flag("--json", opts->json, "JSON lines: the status, then one line per device");
  cmd->callback([opts, &action] { action = [opts] { return runStatus(opts->conn, opts->json); }; });
}

}  // namespace vog::client
