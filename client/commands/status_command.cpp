// `vogctl status`: the daemon's mission state, pose, uncertainty, devices, map and planner.

#include "command_util.hpp"
#include "vog/client/json_line.hpp"

#include <cstdio>
#include <numbers>

namespace vog::client {

namespace {
constexpr double kRadToDeg = 180.0 / std::numbers::pi;
}  // namespace

int runStatusCommand(const StatusOptions& o, const CommandIo& io) {
  auto conn = openConnection(o.conn, io, "status");
  if (!conn.client) return conn.exit_code;
  auto status = conn.client->status();
  if (!status) {
    detail::report(io, "status", status.error().message);
    return conn.client->broken() ? kExitUsage : kExitRefused;
  }
  const api::StatusReport& s = *status;
  const Eigen::Vector3d t = s.T_world_vehicle.translation();
  const Eigen::Vector3d rpy = geometry::rpyFromRotation(s.T_world_vehicle.linear());
  if (o.json) {
    JsonLine line;
    line.add("stamp_ns", static_cast<std::int64_t>(s.stamp_ns))
        .add("mission_state", api::toString(s.mission_state))
        .add("planner_state", api::toString(s.planner_state))
        .add("x_m", t.x())
        .add("y_m", t.y())
        .add("z_m", t.z())
        .add("roll_rad", rpy.x())
        .add("pitch_rad", rpy.y())
        .add("yaw_rad", rpy.z())
        .add("sigma_x_m", s.sigma_xyz_m.x())
        .add("sigma_y_m", s.sigma_xyz_m.y())
        .add("sigma_z_m", s.sigma_xyz_m.z())
        .add("sigma_yaw_rad", s.sigma_yaw_rad)
        .add("n_submaps", static_cast<unsigned>(s.n_submaps))
        .add("n_closures", static_cast<unsigned>(s.n_closures))
        .add("map_version", static_cast<std::uint64_t>(s.map_version));
    io.out << line.str() << '\n';
    for (const auto& d : s.devices) {
      JsonLine dl;
      dl.add("device", d.name)
          .add("state", api::toString(d.state))
          .add("detail", d.detail)
          .add("last_stamp_ns", static_cast<std::int64_t>(d.last_stamp_ns))
          .add("messages", static_cast<std::uint64_t>(d.messages))
          .add("errors", static_cast<std::uint64_t>(d.errors));
      io.out << dl.str() << '\n';
    }
    io.out.flush();
    return kExitOk;
  }
  char buf[256];
  io.out << "mission   " << api::toString(s.mission_state) << "\nplanner   " << api::toString(s.planner_state) << '\n';
  std::snprintf(buf, sizeof buf, "pose      x %.3f  y %.3f  z %.3f m   yaw %.1f deg", t.x(), t.y(), t.z(),
                rpy.z() * kRadToDeg);
  io.out << buf << '\n';
  std::snprintf(buf, sizeof buf, "sigma     x %.3f  y %.3f  z %.3f m   yaw %.2f deg", s.sigma_xyz_m.x(),
                s.sigma_xyz_m.y(), s.sigma_xyz_m.z(), s.sigma_yaw_rad * kRadToDeg);
  io.out << buf << '\n';
  io.out << "map       " << s.n_submaps << " submaps, " << s.n_closures << " loop closures, version " << s.map_version
         << '\n';
  for (const auto& d : s.devices) {
    std::snprintf(buf, sizeof buf, "device    %-12s %-12s %8llu msgs %6llu errors  %s", d.name.c_str(),
                  api::toString(d.state), static_cast<unsigned long long>(d.messages),
                  static_cast<unsigned long long>(d.errors), d.detail.c_str());
    io.out << buf << '\n';
  }
  io.out.flush();
  return kExitOk;
}

}  // namespace vog::client
