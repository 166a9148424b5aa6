// vogd: the VOG mapping-and-planning daemon.
//   vogd --config F                     run (until SIGTERM/SIGINT)
//   vogd --config F --check-config      check the configuration, the files it names and the mission
//                                       folder as vogd would use them, and exit (systemd ExecStartPre)
//   vogd --config F --replay DIR --out OUT   re-run a recorded mission's mapping offline
// Exit codes: 0 ok, 1 stopped by an error, 2 bad configuration or arguments.
#include "vog/app/daemon.hpp"
#include "vog/app/replay.hpp"
#include "vog/app/vogd_config.hpp"

#include <CLI/CLI.hpp>
#include <google/protobuf/stubs/logging.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/sinks/systemd_sink.h>
#include <spdlog/spdlog.h>

#include <cstdlib>

namespace {

// Under systemd (stderr connected to the journal) log records go to journald with their priority;
// elsewhere to stderr.
void setupLogging(const std::string& level) {
  std::shared_ptr<spdlog::logger> logger;
  if (std::getenv("JOURNAL_STREAM") != nullptr) {
    logger = std::make_shared<spdlog::logger>("vogd", std::make_shared<spdlog::sinks::systemd_sink_mt>("vogd"));
  } else {
    logger = std::make_shared<spdlog::logger>("vogd", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
  }
  spdlog::set_default_logger(logger);
  spdlog::set_level(level == "debug"     ? spdlog::level::debug
                    : level == "warning" ? spdlog::level::warn
                    : level == "error"   ? spdlog::level::err
                                         : spdlog::level::info);
  // libprotobuf reports malformed client messages through its own logger: route it to ours.
  google::protobuf::SetLogHandler(
      [](google::protobuf::LogLevel, const char* file, int line, const std::string& message) {
        spdlog::warn("protobuf {}:{}: {}", file, line, message);
      });
}

}  // namespace

int main(int argc, char** argv) {
  std::string config_file = "/etc/vogd/vogd.yaml";
  bool check_only = false;
  std::string replay_dir, out_dir, mission_dir, port_file;
  CLI::App app{"vogd: VOG mapping and planning daemon"};
  app.add_option("--config", config_file, "configuration file (config/vogd.yaml documents every key)");
  app.add_flag("--check-config", check_only,
               "check the configuration, the files it names and the mission folder, and exit");
  app.add_option("--mission-dir", mission_dir, "mission folder (default: mission.directory/mission.name)");
  app.add_option("--port-file", port_file, "write the API port here once listening (api.port 0 picks one)");
  auto* replay = app.add_option("--replay", replay_dir, "re-run the mapping of a recorded mission folder offline");
  app.add_option("--out", out_dir, "with --replay: folder for the replayed submaps, journal and map.bt")->needs(replay);
  CLI11_PARSE(app, argc, argv);

  auto config = vog::app::loadVogdConfig(config_file);
  if (!config) {
    spdlog::error("{}", config.error().message);
    return 2;
  }
  setupLogging(config->log_level);
  if (check_only) {
    // The folder vogd would open (Daemon::init); the files the configuration names were checked above.
    const vog::Status dir = mission_dir.empty()
                                ? vog::app::checkMissionDirectory(config->mission.directory / config->mission.name,
                                                                  config->mission.directory_setting)
                                : vog::app::checkMissionDirectory(mission_dir, "--mission-dir");
    if (!dir.ok()) {
      spdlog::error("{}", dir.error().message);
      return 2;
    }
    spdlog::info("{}: configuration ok ({} source)", config_file,
                 config->source == vog::app::Source::kSim ? "simulator" : "device");
    return 0;
  }
  if (!replay_dir.empty()) {
    if (out_dir.empty()) {
      spdlog::error("--replay needs --out");
      return 2;
    }
    auto stats = vog::app::replayMission(*config, replay_dir, out_dir);
    if (!stats) {
      spdlog::error("{}", stats.error().message);
      return 1;
    }
    spdlog::info(
        "replayed {} scans: {} submaps, {} loop closures ({} records skipped, {} scans rejected, {} outside the "
        "mission); {}/map.bt",
        stats->scans, stats->submaps, stats->closures, stats->skipped_records, stats->rejected_scans, stats->not_mapped,
        out_dir);
    return 0;
  }

  vog::app::DaemonOptions options;
  if (!mission_dir.empty()) options.mission_dir = mission_dir;
  if (!port_file.empty()) options.port_file = port_file;
  auto daemon = vog::app::Daemon::create(*config, options);
  if (!daemon) {
    spdlog::error("{}", daemon.error().message);
    return 2;
  }
  const vog::Status stopped = (*daemon)->run();
  if (!stopped) spdlog::error("stopped: {}", stopped.error().message);
  // run() returned with every thread joined and the mission durable (the active submap stored, the
  // journal synced). Freeing the mission's memory (every submap's tree: seconds for a long mission)
  // would only delay the exit systemd waits for; the process ends without it.
  spdlog::shutdown();
  std::_Exit(stopped ? 0 : 1);
}
