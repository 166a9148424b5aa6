#pragma once
// vogctl subcommands. Each lives in its own file and adds itself to the application here; main()
// calls every add*Command and runs the one selected on the command line.

#include <CLI/CLI.hpp>

#include <functional>

namespace vog::client {

// The action of the selected subcommand, returning the process exit code.
using CommandAction = std::function<int()>;

// `vogctl decode --format F FILE [--json]`: print what a device recording contains.
void addDecodeCommand(CLI::App& app, CommandAction& action);

// `vogctl status [--json]`: vogd's status (connection options: --host --port --secret-file).
void addStatusCommand(CLI::App& app, CommandAction& action);
// `vogctl watch [--waypoints] [--poses] [--status] [--count N] [--json]`: vogd's streams.
void addWatchCommand(CLI::App& app, CommandAction& action);
// `vogctl snapshot --out map.bt|map.ot [--json]`: vogd's merged map, with progress.
void addSnapshotCommand(CLI::App& app, CommandAction& action);

}  // namespace vog::client
