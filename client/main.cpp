// vogctl: command-line client of the VOG daemon and its device recordings (client/README.md).

#include "commands.hpp"
#include "vog/client/vogctl.hpp"

#include <unistd.h>

#include <iostream>

int main(int argc, char** argv) {
  const vog::client::CommandIo io{std::cout, std::cerr, isatty(STDERR_FILENO) != 0};
  CLI::App app{"vogctl: VOG command-line client"};
  app.require_subcommand(1);
  vog::client::CommandAction action;
  vog::client::addDecodeCommand(app, action);
  vog::client::addApiCommands(app, action, io);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return vog::client::reportParseError(app, e, io);
  }
  return action ? action() : vog::client::kExitUsage;
}
