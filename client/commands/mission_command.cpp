// `vogctl mission start|pause|resume|abort|return-home|set-box`: operator commands (the mission
// lifecycle). They need the operator secret; vogd answers with the mission state or a refusal.

#include "command_util.hpp"
#include "vog/client/json_line.hpp"

#include <cstdio>

namespace vog::client {

namespace {

using Kind = api::MissionCommand::Kind;

const char* verb(Kind k) {
  switch (k) {
    case Kind::kSetBox: return "set-box";
    case Kind::kStart: return "start";
    case Kind::kPause: return "pause";
    case Kind::kResume: return "resume";
    case Kind::kAbort: return "abort";
    case Kind::kReturnHome: return "return-home";
  }
  return "?";
}

}  // namespace

int runMissionCommand(const MissionOptions& o, const CommandIo& io) {
  const std::string name = std::string("mission ") + verb(o.kind);
  // Checked before connecting: a usage error costs no round trip.
  std::vector<api::MissionCommand> commands;
  if (!o.box.empty()) {
    if (o.kind != Kind::kSetBox && o.kind != Kind::kStart) {
      detail::report(io, name, "--box applies to start and set-box only");
      return kExitUsage;
    }
    auto box = parseBox(o.box);
    if (!box) {
      detail::report(io, name, box.error().message);
      return kExitUsage;
    }
    commands.push_back({Kind::kSetBox, *box});
  } else if (o.kind == Kind::kSetBox) {
    detail::report(io, name, "needs --box xmin,ymin,zmin,xmax,ymax,zmax");
    return kExitUsage;
  }
  if (o.kind != Kind::kSetBox) commands.push_back({o.kind, {}});

  auto conn = openConnection(o.conn, io, name, /*need_operator=*/true);
  if (!conn.client) return conn.exit_code;
  for (const auto& command : commands) {
    auto state = conn.client->command(command);
    if (!state) {
      detail::report(io, name, std::string(verb(command.kind)) + " refused by vogd: " + state.error().message);
      return conn.client->broken() ? kExitUsage : kExitRefused;
    }
    if (o.json) {
      JsonLine line;
      line.add("command", verb(command.kind)).add("mission_state", api::toString(*state));
      if (command.kind == Kind::kSetBox) {
        line.add("min_x_m", command.box.min_world_m.x())
            .add("min_y_m", command.box.min_world_m.y())
            .add("min_z_m", command.box.min_world_m.z())
            .add("max_x_m", command.box.max_world_m.x())
            .add("max_y_m", command.box.max_world_m.y())
            .add("max_z_m", command.box.max_world_m.z());
      }
      io.out << line.str() << std::endl;
    } else {
      io.out << verb(command.kind) << ": accepted, mission " << api::toString(*state) << std::endl;
    }
  }
  return kExitOk;
}

}  // namespace vog::client
