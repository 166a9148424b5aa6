#pragma once
// `vogctl decode`, the one subcommand that reads files instead of talking to vogd (it links the
// device codecs, which the API commands of vog/client/vogctl.hpp do not need).

#include "vog/client/vogctl.hpp"

#include <CLI/CLI.hpp>

namespace vog::client {

// `vogctl decode --format F FILE [--json]`: print what a device recording contains.
void addDecodeCommand(CLI::App& app, CommandAction& action);

}  // namespace vog::client
