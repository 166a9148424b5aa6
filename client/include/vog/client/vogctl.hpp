#pragma once
// vogctl's commands that talk to vogd (client/README.md): each is a function of its options that
// writes its result to an output stream, so the executable and the tests run the same code.
// Results go to `out` (human-readable text, or one JSON object per line with --json); messages and
// progress go to `err`.

#include "vog/api/domain.hpp"
#include "vog/client/api_client.hpp"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace vog::client {

// Exit codes of every vogctl command.
inline constexpr int kExitOk = 0;
inline constexpr int kExitRefused = 1;  // the server refused the request or answered with an error
inline constexpr int kExitUsage = 2;    // bad options, unreadable/unwritable files, no connection

inline constexpr std::uint16_t kDefaultApiPort = 29600;  // vogd's api.port default (config/vogd.yaml)

// Where a command writes.
struct CommandIo {
  std::ostream& out;
  std::ostream& err;
  bool err_is_terminal = false;  // progress lines on `err` only for a terminal (or with --progress)
};

// --host, --port, --secret-file, --timeout-ms: shared by every command that talks to vogd.
struct ConnectionOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = kDefaultApiPort;
  std::string secret_file;  // when set: authenticate as operator
  int timeout_ms = 10000;
  bool tls = false;     // TLS (vogd's api.tls), the server verified against ca_file
  std::string ca_file;  // PEM; empty: the system's trusted CAs

  void addTo(CLI::App& cmd);
  // The client's configuration: the timeout and TLS.
  ClientConfig clientConfig() const;
};

// The secret file's content without a trailing newline (an editor's or `echo`'s, not the secret's);
// errors name the file (missing, empty, longer than a secret).
Result<std::string> readSecretFile(const std::string& file);

// An open connection, or the exit code of the failure (already reported on `err`).
struct Connection {
  std::unique_ptr<ApiClient> client;
  int exit_code = kExitOk;
};

// Connects, and authenticates as operator when a secret file is given (or `need_operator`, which
// refuses without one). Connection and file failures give kExitUsage, a refused authentication
// kExitRefused; `command` prefixes the messages.
Connection openConnection(const ConnectionOptions& options, const CommandIo& io, const std::string& command,
                          bool need_operator = false);

// "xmin,ymin,zmin,xmax,ymax,zmax" in metres, world frame; errors name the bad field and value.
Result<api::ExplorationBox> parseBox(const std::string& text);

struct StatusOptions {
  ConnectionOptions conn;
  bool json = false;
};
int runStatusCommand(const StatusOptions& o, const CommandIo& io);

struct WatchOptions {
  ConnectionOptions conn;
  bool waypoints = false;
  bool poses = false;
  bool status = false;
  bool json = false;
  int count = 0;           // 0 = until interrupted
  int idle_timeout_s = 0;  // 0 = wait forever
};
int runWatchCommand(const WatchOptions& o, const CommandIo& io);

struct WaypointsOptions {
  ConnectionOptions conn;
  bool json = false;
  int count = 0;  // 0 = until interrupted
};
int runWaypointsCommand(const WaypointsOptions& o, const CommandIo& io);

struct MissionOptions {
  ConnectionOptions conn;
  api::MissionCommand::Kind kind = api::MissionCommand::Kind::kStart;
  std::string box;  // parseBox format; required by set-box, optional for start (set, then start)
  bool json = false;
};
int runMissionCommand(const MissionOptions& o, const CommandIo& io);

struct SubmapsOptions {
  ConnectionOptions conn;
  bool json = false;
};
int runSubmapsCommand(const SubmapsOptions& o, const CommandIo& io);

struct ConfigOptions {
  ConnectionOptions conn;
  bool json = false;
};
int runConfigCommand(const ConfigOptions& o, const CommandIo& io);

struct SnapshotOptions {
  ConnectionOptions conn;
  std::string out;  // .bt or .ot
  bool json = false;
  bool progress = false;  // progress on err even when it is not a terminal
};
int runSnapshotCommand(const SnapshotOptions& o, const CommandIo& io);

struct CloudOptions {
  ConnectionOptions conn;
  std::string out;  // .ply
  bool json = false;
  bool progress = false;
};
int runCloudCommand(const CloudOptions& o, const CommandIo& io);

struct TopViewOptions {
  ConnectionOptions conn;
  std::string out;        // .png
  double px_per_m = 0.0;  // 0: one pixel per voxel
  int max_side_px = 16384;
  bool json = false;
  bool progress = false;
};
int runTopViewCommand(const TopViewOptions& o, const CommandIo& io);

// The action of the subcommand selected on the command line, returning the exit code.
using CommandAction = std::function<int()>;

// Adds status, watch, waypoints, mission, submaps, config, snapshot, cloud and topview to `app`;
// the one parsed sets `action`. `io` must outlive the action.
void addApiCommands(CLI::App& app, CommandAction& action, const CommandIo& io);

// Parses `args` (without the program name) with an app holding the API commands and runs the
// selected one: what the vogctl executable does for these commands, including exit codes for
// usage errors (kExitUsage) and --help (kExitOk, help on `out`).
int runVogctl(const std::vector<std::string>& args, const CommandIo& io);
// The exit code and messages for a parse error of `app` (help requests are not errors).
int reportParseError(const CLI::App& app, const CLI::ParseError& e, const CommandIo& io);

}  // namespace vog::client
