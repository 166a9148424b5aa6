// `vogctl watch` and `vogctl waypoints`: vogd's streams, printed as they arrive.

#include "command_util.hpp"
#include "vog/client/json_line.hpp"

#include <cstdio>

namespace vog::client {

namespace {

void printPose(const CommandIo& io, const char* kind, std::uint64_t seq, std::int64_t stamp_ns,
               const geometry::Pose3& T, std::uint64_t dropped, bool json) {
  const Eigen::Vector3d t = T.translation();
  const double yaw = geometry::yawOf(T.linear());
  if (json) {
    JsonLine line;
    line.add("stream", kind)
        .add("seq", seq)
        .add("stamp_ns", static_cast<std::int64_t>(stamp_ns))
        .add("x_m", t.x())
        .add("y_m", t.y())
        .add("z_m", t.z())
        .add("yaw_rad", yaw)
        .add("dropped", dropped);
    io.out << line.str() << std::endl;
    return;
  }
  char buf[200];
  std::snprintf(buf, sizeof buf, "%-8s #%llu  t=%.3f s  x %.3f  y %.3f  z %.3f m  yaw %.3f rad%s", kind,
                static_cast<unsigned long long>(seq), static_cast<double>(stamp_ns) * 1e-9, t.x(), t.y(), t.z(), yaw,
                dropped > 0 ? "  (some dropped: slow link)" : "");
  io.out << buf << std::endl;
}

void printWaypoint(const CommandIo& io, const api::Waypoint& w, bool json) {
  const Eigen::Vector3d t = w.T_world_target.translation();
  const double yaw = geometry::yawOf(w.T_world_target.linear());
  if (json) {
    JsonLine line;
    line.add("seq", static_cast<std::uint64_t>(w.seq))
        .add("stamp_ns", static_cast<std::int64_t>(w.stamp_ns))
        .add("x_m", t.x())
        .add("y_m", t.y())
        .add("z_m", t.z())
        .add("yaw_rad", yaw)
        .add("speed_mps", w.speed_mps)
        .add("dropped", static_cast<std::uint64_t>(w.dropped));
    io.out << line.str() << std::endl;
    return;
  }
  char buf[220];
  std::snprintf(buf, sizeof buf, "waypoint #%llu  t=%.3f s  x %.3f  y %.3f  z %.3f m  yaw %.3f rad  %.2f m/s",
                static_cast<unsigned long long>(w.seq), static_cast<double>(w.stamp_ns) * 1e-9, t.x(), t.y(), t.z(),
                yaw, w.speed_mps);
  io.out << buf;
  if (w.dropped > 0) io.out << "  (" << w.dropped << " dropped so far: slow link)";
  io.out << std::endl;
}

// Receives stream messages until `count` (0: forever) were handed to `print`, or an idle timeout
// (0: none). A connection that breaks is a connection error.
template <class Print>
int streamLoop(ApiClient& c, const CommandIo& io, const char* command, int count, int idle_timeout_s, Print print) {
  const auto timeout = idle_timeout_s > 0 ? std::chrono::milliseconds(idle_timeout_s * 1000LL)
                                          : std::chrono::milliseconds(3600LL * 1000);
  for (int n = 0; count == 0 || n < count;) {
    auto m = c.nextStream(timeout);
    if (!m) {
      if (!c.broken()) {
        if (idle_timeout_s > 0) return kExitOk;                                // idle for the given time: done
        if (c.lastServerError().code == v1::ERROR_CODE_UNSPECIFIED) continue;  // quiet hour: keep waiting
        detail::report(io, command, m.error().message);
        return kExitRefused;
      }
      detail::report(io, command, m.error().message);
      return kExitUsage;
    }
    if (print(*m)) ++n;
  }
  return kExitOk;
}

}  // namespace

int runWatchCommand(const WatchOptions& o, const CommandIo& io) {
  api::Subscriptions subs{o.waypoints, o.poses, o.status};
  if (!subs.waypoints && !subs.poses && !subs.status) subs = {true, true, false};
  auto conn = openConnection(o.conn, io, "watch");
  if (!conn.client) return conn.exit_code;
  if (auto r = conn.client->subscribe(subs); !r) {
    detail::report(io, "watch", "subscribe: " + r.error().message);
    return conn.client->broken() ? kExitUsage : kExitRefused;
  }
  return streamLoop(*conn.client, io, "watch", o.count, o.idle_timeout_s, [&](const StreamMessage& m) {
    if (const auto* w = std::get_if<api::Waypoint>(&m)) {
      printPose(io, "waypoint", w->seq, w->stamp_ns, w->T_world_target, w->dropped, o.json);
    } else if (const auto* p = std::get_if<api::PoseUpdate>(&m)) {
      printPose(io, "pose", p->seq, p->stamp_ns, p->T_world_vehicle, p->dropped, o.json);
    } else if (const auto* s = std::get_if<api::StatusUpdate>(&m)) {
      if (o.json) {
        JsonLine line;
        line.add("stream", "status")
            .add("seq", s->seq)
            .add("mission_state", api::toString(s->status.mission_state))
            .add("planner_state", api::toString(s->status.planner_state))
            .add("n_submaps", static_cast<unsigned>(s->status.n_submaps))
            .add("map_version", static_cast<std::uint64_t>(s->status.map_version));
        io.out << line.str() << std::endl;
      } else {
        io.out << "status   #" << s->seq << "  mission " << api::toString(s->status.mission_state) << ", planner "
               << api::toString(s->status.planner_state) << ", " << s->status.n_submaps << " submaps, map version "
               << s->status.map_version << std::endl;
      }
    }
    return true;
  });
}

int runWaypointsCommand(const WaypointsOptions& o, const CommandIo& io) {
  auto conn = openConnection(o.conn, io, "waypoints");
  if (!conn.client) return conn.exit_code;
  if (auto r = conn.client->subscribe({true, false, false}); !r) {
    detail::report(io, "waypoints", "subscribe: " + r.error().message);
    return conn.client->broken() ? kExitUsage : kExitRefused;
  }
  return streamLoop(*conn.client, io, "waypoints", o.count, 0, [&](const StreamMessage& m) {
    const auto* w = std::get_if<api::Waypoint>(&m);
    if (w == nullptr) return false;  // only waypoints were subscribed; anything else is not counted
    printWaypoint(io, *w, o.json);
    return true;
  });
}

}  // namespace vog::client
