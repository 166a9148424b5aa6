// `vogctl watch`: prints vogd's waypoint, pose and status streams as they arrive.

#include "commands.hpp"
#include "connection_options.hpp"
#include "json_line.hpp"

#include <iostream>

namespace vog::client {
namespace {

struct WatchOptions {
  ConnectionOptions conn;
  bool waypoints = false;
  bool poses = false;
  bool status = false;
  bool json = false;
  int count = 0;           // 0 = until interrupted
  int idle_timeout_s = 0;  // 0 = wait forever
};

void print(const char* kind, std::uint64_t seq, std::int64_t stamp_ns, const geometry::Pose3& T,
           std::uint64_t dropped, bool json) {
  const Eigen::Vector3d t = T.translation();
  const double yaw = geometry::yawOf(T.linear());
  if (json) {
    JsonLine line;
    line.add("stream", kind).add("seq", seq).add("stamp_ns", static_cast<std::int64_t>(stamp_ns))
        .add("x_m", t.x()).add("y_m", t.y()).add("z_m", t.z()).add("yaw_rad", yaw).add("dropped", dropped);
    std::cout << line.str() << std::endl;
    return;
  }
  char buf[200];
  std::snprintf(buf, sizeof buf, "%-8s #%llu  t=%.3f s  x %.3f  y %.3f  z %.3f m  yaw %.3f rad%s", kind,
                static_cast<unsigned long long>(seq), static_cast<double>(stamp_ns) * 1e-9, t.x(), t.y(), t.z(), yaw,
                dropped > 0 ? "  (some dropped: slow link)" : "");
  std::cout << buf << std::endl;
}

int runWatch(const WatchOptions& o) {
  api::Subscriptions subs{o.waypoints, o.poses, o.status};
  if (!subs.waypoints && !subs.poses && !subs.status) subs = {true, true, false};
  auto c = o.conn.open();
  if (!c) return 1;
  if (auto r = c->subscribe(subs); !r) {
    std::fprintf(stderr, "vogctl: subscribe: %s\n", r.error().message.c_str());
    return 1;
  }
  const auto timeout = o.idle_timeout_s > 0 ? std::chrono::milliseconds(o.idle_timeout_s * 1000)
                                            : std::chrono::milliseconds(24LL * 3600 * 1000);
  for (int n = 0; o.count == 0 || n < o.count;) {
    auto m = c->nextStream(timeout);
    if (!m) {
      if (o.idle_timeout_s > 0 && !c->broken()) return 0;  // idle for the given time: done
      if (o.idle_timeout_s == 0 && !c->broken()) continue;
      std::fprintf(stderr, "vogctl: %s\n", m.error().message.c_str());
      return 1;
    }
    ++n;
    if (const auto* w = std::get_if<api::Waypoint>(&*m)) {
      print("waypoint", w->seq, w->stamp_ns, w->T_world_target, w->dropped, o.json);
    } else if (const auto* p = std::get_if<api::PoseUpdate>(&*m)) {
      print("pose", p->seq, p->stamp_ns, p->T_world_vehicle, p->dropped, o.json);
    } else if (const auto* s = std::get_if<api::StatusUpdate>(&*m)) {
      if (o.json) {
        JsonLine line;
        line.add("stream", "status").add("seq", s->seq).add("mission_state", api::toString(s->status.mission_state))
            .add("planner_state", api::toString(s->status.planner_state))
            .add("n_submaps", static_cast<unsigned>(s->status.n_submaps))
            .add("map_version", static_cast<std::uint64_t>(s->status.map_version));
        std::cout << line.str() << std::endl;
      } else {
        std::cout << "status   #" << s->seq << "  mission " << api::toString(s->status.mission_state) << ", planner "
                  << api::toString(s->status.planner_state) << ", " << s->status.n_submaps << " submaps, map version "
                  << s->status.map_version << std::endl;
      }
    }
  }
  return 0;
}

}  // namespace

void addWatchCommand(CLI::App& app, CommandAction& action) {
  auto* cmd = app.add_subcommand("watch", "Print vogd's waypoint, pose and status streams (default: waypoints and poses)");
  auto opts = std::make_shared<WatchOptions>();
  opts->conn.addTo(*cmd);
  cmd->add_flag("--waypoints", opts->waypoints, "Waypoints sent to the vehicle");
  cmd->add_flag("--poses", opts->poses, "Vehicle poses");
  cmd->add_flag("--status", opts->status, "Status updates");
  cmd->add_option("--count", opts->count, "Stop after this many messages (0: run until interrupted)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--idle-timeout-s", opts->idle_timeout_s, "Stop after this long without a message (0: never)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--json", opts->json, "One JSON object per line");
  cmd->callback([opts, &action] { action = [opts] { return runWatch(*opts); }; });
}

}  // namespace vog::client
