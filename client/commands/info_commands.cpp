// `vogctl submaps` (the submap list with poses) and `vogctl config` (the daemon's configuration).

#include "command_util.hpp"
#include "vog/client/json_line.hpp"

#include <cstdio>

namespace vog::client {

int runSubmapsCommand(const SubmapsOptions& o, const CommandIo& io) {
  auto conn = openConnection(o.conn, io, "submaps");
  if (!conn.client) return conn.exit_code;
  auto submaps = conn.client->submaps();
  if (!submaps) {
    detail::report(io, "submaps", submaps.error().message);
    return conn.client->broken() ? kExitUsage : kExitRefused;
  }
  if (!o.json) {
    io.out << "   id  closed  scans        x_m        y_m        z_m   roll_rad  pitch_rad    yaw_rad   first_s    "
              "last_s\n";
  }
  for (const api::SubmapInfo& s : *submaps) {
    const Eigen::Vector3d t = s.T_world_submap.translation();
    const Eigen::Vector3d rpy = geometry::rpyFromRotation(s.T_world_submap.linear());
    if (o.json) {
      JsonLine line;
      line.add("id", static_cast<unsigned>(s.id))
          .add("closed", s.closed)
          .add("n_scans", static_cast<unsigned>(s.n_scans))
          .add("first_stamp_ns", static_cast<std::int64_t>(s.first_stamp_ns))
          .add("last_stamp_ns", static_cast<std::int64_t>(s.last_stamp_ns))
          .add("x_m", t.x())
          .add("y_m", t.y())
          .add("z_m", t.z())
          .add("roll_rad", rpy.x())
          .add("pitch_rad", rpy.y())
          .add("yaw_rad", rpy.z());
      io.out << line.str() << '\n';
      continue;
    }
    char buf[200];
    std::snprintf(buf, sizeof buf, "%5u  %-6s %6u %10.3f %10.3f %10.3f %10.4f %10.4f %10.4f %9.3f %9.3f", s.id,
                  s.closed ? "yes" : "no", s.n_scans, t.x(), t.y(), t.z(), rpy.x(), rpy.y(), rpy.z(),
                  static_cast<double>(s.first_stamp_ns) * 1e-9, static_cast<double>(s.last_stamp_ns) * 1e-9);
    io.out << buf << '\n';
  }
  io.out.flush();
  return kExitOk;
}

int runConfigCommand(const ConfigOptions& o, const CommandIo& io) {
  auto conn = openConnection(o.conn, io, "config");
  if (!conn.client) return conn.exit_code;
  auto text = conn.client->configText();
  if (!text) {
    detail::report(io, "config", text.error().message);
    return conn.client->broken() ? kExitUsage : kExitRefused;
  }
  if (o.json) {
    JsonLine line;
    line.add("config", *text);
    io.out << line.str() << std::endl;
  } else {
    io.out << *text;
    if (!text->empty() && text->back() != '\n') io.out << '\n';
    io.out.flush();
  }
  return kExitOk;
}

}  // namespace vog::client
