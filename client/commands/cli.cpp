// The command-line front of the API commands: options of each subcommand, parsing, exit codes.

#include "vog/client/vogctl.hpp"

#include <algorithm>

namespace vog::client {

namespace {

// Options live in shared_ptrs owned by the callbacks, so they outlive parsing and the action.
template <class Options, class Run>
void addCommand(CLI::App& parent, CommandAction& action, const CommandIo& io, const char* name, const char* help,
                const std::shared_ptr<Options>& opts, Run run, CLI::App** cmd_out) {
  auto* cmd = parent.add_subcommand(name, help);
  opts->conn.addTo(*cmd);
  cmd->add_flag("--json", opts->json, "One JSON object per line");
  cmd->callback([opts, &action, &io, run] { action = [opts, &io, run] { return run(*opts, io); }; });
  *cmd_out = cmd;
}

}  // namespace

void addApiCommands(CLI::App& app, CommandAction& action, const CommandIo& io) {
  CLI::App* cmd = nullptr;

  addCommand(app, action, io, "status", "Mission state, pose, uncertainty, devices, map and planner of vogd",
             std::make_shared<StatusOptions>(), runStatusCommand, &cmd);

  auto watch = std::make_shared<WatchOptions>();
  addCommand(app, action, io, "watch", "Print vogd's waypoint, pose and status streams (default: waypoints and poses)",
             watch, runWatchCommand, &cmd);
  cmd->add_flag("--waypoints", watch->waypoints, "Waypoints sent to the vehicle");
  cmd->add_flag("--poses", watch->poses, "Vehicle poses");
  cmd->add_flag("--status", watch->status, "Status updates");
  cmd->add_option("--count", watch->count, "Stop after this many messages (0: run until interrupted)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--idle-timeout-s", watch->idle_timeout_s, "Stop after this long without a message (0: never)")
      ->check(CLI::NonNegativeNumber);

  auto waypoints = std::make_shared<WaypointsOptions>();
  addCommand(app, action, io, "waypoints", "Print the waypoints vogd sends the vehicle (seq, stamp, pose, speed)",
             waypoints, runWaypointsCommand, &cmd);
  cmd->add_option("--count", waypoints->count, "Stop after this many waypoints (0: run until interrupted)")
      ->check(CLI::NonNegativeNumber);

  auto* mission = app.add_subcommand("mission", "Operator commands (need --secret-file)");
  mission->require_subcommand(1);
  using Kind = api::MissionCommand::Kind;
  const struct {
    const char* name;
    Kind kind;
    const char* help;
  } kMission[] = {
      {"start", Kind::kStart, "Start exploring (with --box: set the exploration box first)"},
      {"pause", Kind::kPause, "Pause the mission (the vehicle holds position)"},
      {"resume", Kind::kResume, "Resume a paused mission"},
      {"abort", Kind::kAbort, "Abort the mission"},
      {"return-home", Kind::kReturnHome, "Stop exploring and return to the start"},
      {"set-box", Kind::kSetBox, "Set the exploration box (--box)"},
  };
  for (const auto& m : kMission) {
    auto opts = std::make_shared<MissionOptions>();
    opts->kind = m.kind;
    addCommand(*mission, action, io, m.name, m.help, opts, runMissionCommand, &cmd);
    if (m.kind == Kind::kStart || m.kind == Kind::kSetBox) {
      auto* box = cmd->add_option("--box", opts->box, "Exploration box xmin,ymin,zmin,xmax,ymax,zmax (metres, world)");
      if (m.kind == Kind::kSetBox) box->required();
    }
  }

  addCommand(app, action, io, "submaps", "List vogd's submaps with their poses", std::make_shared<SubmapsOptions>(),
             runSubmapsCommand, &cmd);
  addCommand(app, action, io, "config", "Print vogd's configuration", std::make_shared<ConfigOptions>(),
             runConfigCommand, &cmd);

  auto snapshot = std::make_shared<SnapshotOptions>();
  addCommand(app, action, io, "snapshot", "Fetch vogd's merged map and write it as .bt or .ot (octovis)", snapshot,
             runSnapshotCommand, &cmd);
  cmd->add_option("--out", snapshot->out, "Output file, .bt or .ot")->required();
  cmd->add_flag("--progress", snapshot->progress, "Progress on stderr even when it is not a terminal");

  auto cloud = std::make_shared<CloudOptions>();
  addCommand(app, action, io, "cloud", "Fetch vogd's reconstruction and write it as binary PLY", cloud, runCloudCommand,
             &cmd);
  cmd->add_option("--out", cloud->out, "Output file, .ply")->required();
  cmd->add_flag("--progress", cloud->progress, "Progress on stderr even when it is not a terminal");

  auto topview = std::make_shared<TopViewOptions>();
  addCommand(app, action, io, "topview", "Fetch vogd's merged map and render it from above as PNG", topview,
             runTopViewCommand, &cmd);
  cmd->add_option("--out", topview->out, "Output file, .png")->required();
  cmd->add_option("--px-per-m", topview->px_per_m, "Pixels per metre (0: one pixel per voxel)")->capture_default_str();
  cmd->add_option("--max-side-px", topview->max_side_px, "Refuse images larger than this per side")
      ->capture_default_str();
  cmd->add_flag("--progress", topview->progress, "Progress on stderr even when it is not a terminal");
}

int reportParseError(const CLI::App& app, const CLI::ParseError& e, const CommandIo& io) {
  // Help (and version) requests are ParseErrors with exit code 0.
  const int code = app.exit(e, io.out, io.err);
  return code == 0 ? kExitOk : kExitUsage;
}

int runVogctl(const std::vector<std::string>& args, const CommandIo& io) {
  CLI::App app{"vogctl: VOG command-line client"};
  app.require_subcommand(1);
  CommandAction action;
  addApiCommands(app, action, io);
  std::vector<std::string> reversed(args.rbegin(), args.rend());  // CLI11 takes arguments last first
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    return reportParseError(app, e, io);
  }
  return action ? action() : kExitUsage;
}

}  // namespace vog::client
