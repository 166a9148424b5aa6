// vogd: the VOG mapping-and-planning daemon. This entry point reads and validates the
// configuration; `--check-config` stops there (systemd's ExecStartPre and the operator use it).
#include "vog/app/vogd_config.hpp"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

int main(int argc, char** argv) {
  std::string config_file = "/etc/vogd/vogd.yaml";
  bool check_only = false;
  CLI::App app{"vogd: VOG mapping and planning daemon"};
  app.add_option("--config", config_file, "configuration file (config/vogd.yaml documents every key)");
  app.add_flag("--check-config", check_only, "validate the configuration and exit");
  CLI11_PARSE(app, argc, argv);

  auto config = vog::app::loadVogdConfig(config_file);
  if (!config) {
    spdlog::error("{}", config.error().message);
    return 2;
  }
  if (check_only) {
    spdlog::info("{}: configuration ok ({} source)", config_file,
                 config->source == vog::app::Source::kSim ? "simulator" : "device");
    return 0;
  }
  spdlog::error("{}: running a mission is not available in this build; use --check-config", config_file);
  return 3;
}
