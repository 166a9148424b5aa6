// vogctl: command-line client of the VOG daemon and its device recordings.

#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"vogctl: VOG command-line client"};
  app.require_subcommand(1);
  vog::client::CommandAction action;
  vog::client::addDecodeCommand(app, action);
  vog::client::addStatusCommand(app, action);
  vog::client::addWatchCommand(app, action);
  vog::client::addSnapshotCommand(app, action);
  CLI11_PARSE(app, argc, argv);
  return action ? action() : 1;
}
