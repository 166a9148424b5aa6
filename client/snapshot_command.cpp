// `vogctl snapshot --out map.bt|map.ot`: fetches vogd's merged map and writes it for octovis.

#include "commands.hpp"
#include "connection_options.hpp"
#include "json_line.hpp"

#include <iostream>

namespace vog::client {
namespace {

struct SnapshotOptions {
  ConnectionOptions conn;
  std::string out;
  bool json = false;
};

int runSnapshot(const SnapshotOptions& o) {
  const std::filesystem::path out(o.out);
  const std::string ext = out.extension().string();
  if (ext != ".bt" && ext != ".ot") {
    std::fprintf(stderr, "vogctl: --out %s: the file must end in .bt (max-likelihood) or .ot (log-odds)\n",
                 o.out.c_str());
    return 2;
  }
  auto c = o.conn.open();
  if (!c) return 1;
  api::MapMirror mirror;
  // Progress on stderr, so stdout stays clean for --json.
  int last_percent = -1;
  const bool tty_progress = !o.json;
  const Status fetched = c->fetchMap(mirror, [&](std::uint64_t n, std::uint64_t total) {
    const int percent = total == 0 ? 100 : static_cast<int>(100 * n / total);
    if (tty_progress && percent != last_percent) {
      std::fprintf(stderr, "\rmap: %llu / %llu blocks (%d%%)", static_cast<unsigned long long>(n),
                   static_cast<unsigned long long>(total), percent);
      last_percent = percent;
    }
  });
  if (tty_progress) std::fprintf(stderr, "\n");
  if (!fetched.ok()) {
    std::fprintf(stderr, "vogctl: snapshot: %s\n", fetched.error().message.c_str());
    return 1;
  }
  const Status written = ext == ".bt" ? mirror.writeBt(out) : mirror.writeOt(out);
  if (!written.ok()) {
    std::fprintf(stderr, "vogctl: snapshot: %s\n", written.error().message.c_str());
    return 1;
  }
  if (o.json) {
    JsonLine line;
    line.add("out", o.out).add("map_version", static_cast<std::uint64_t>(mirror.version()))
        .add("blocks", static_cast<std::uint64_t>(mirror.blockCount()))
        .add("known_voxels", static_cast<std::uint64_t>(mirror.knownVoxelCount()))
        .add("resolution_m", mirror.resolution());
    std::cout << line.str() << '\n';
  } else {
    std::cout << "wrote " << o.out << ": map version " << mirror.version() << ", " << mirror.knownVoxelCount()
              << " known voxels at " << mirror.resolution() << " m\n";
  }
  return 0;
}

}  // namespace

void addSnapshotCommand(CLI::App& app, CommandAction& action) {
  auto* cmd = app.add_subcommand("snapshot", "Fetch vogd's merged map and write it as .bt or .ot (octovis)");
  auto opts = std::make_shared<SnapshotOptions>();
  opts->conn.addTo(*cmd);
  cmd->add_option("--out", opts->out, "Output file, .bt or .ot")->required();
  cmd->add_flag("--json", opts->json, "A JSON summary instead of text and progress");
  cmd->callback([opts, &action] { action = [opts] { return runSnapshot(*opts); }; });
}

}  // namespace vog::client
