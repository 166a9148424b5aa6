// The commands that fetch large data and write files: `snapshot` (merged map as .bt/.ot for
// octovis), `cloud` (reconstruction as PLY), `topview` (merged map seen from above, PNG).

#include "command_util.hpp"
#include "vog/client/json_line.hpp"
#include "vog/client/ply.hpp"
#include "vog/client/top_view.hpp"

#include <filesystem>

namespace vog::client {

namespace {

// The output file must end in one of `extensions` (lower case).
bool checkExtension(const CommandIo& io, const std::string& command, const std::string& out,
                    std::initializer_list<const char*> extensions, const char* what) {
  const std::string ext = std::filesystem::path(out).extension().string();
  for (const char* e : extensions) {
    if (ext == e) return true;
  }
  detail::report(io, command, "--out " + out + ": the file must end in " + what);
  return false;
}

// Fetches the merged map into `mirror`, with progress; the exit code (failures reported).
int fetchMap(ApiClient& c, api::MapMirror& mirror, const CommandIo& io, const char* command, bool progress) {
  detail::ProgressLine line(io, progress, "map", "blocks");
  const Status fetched = c.fetchMap(mirror, [&](std::uint64_t n, std::uint64_t total) { line.update(n, total); });
  line.finish();
  if (!fetched.ok()) {
    detail::report(io, command, fetched.error().message);
    return c.broken() ? kExitUsage : kExitRefused;
  }
  return kExitOk;
}

}  // namespace

int runSnapshotCommand(const SnapshotOptions& o, const CommandIo& io) {
  if (!checkExtension(io, "snapshot", o.out, {".bt", ".ot"}, ".bt (max-likelihood) or .ot (log-odds)")) {
    return kExitUsage;
  }
  auto conn = openConnection(o.conn, io, "snapshot");
  if (!conn.client) return conn.exit_code;
  api::MapMirror mirror;
  if (int rc = fetchMap(*conn.client, mirror, io, "snapshot", o.progress); rc != kExitOk) return rc;
  const std::filesystem::path out(o.out);
  const Status written = out.extension() == ".bt" ? mirror.writeBt(out) : mirror.writeOt(out);
  if (!written.ok()) {
    detail::report(io, "snapshot", written.error().message);
    return kExitUsage;
  }
  if (o.json) {
    JsonLine line;
    line.add("out", o.out)
        .add("map_version", static_cast<std::uint64_t>(mirror.version()))
        .add("blocks", static_cast<std::uint64_t>(mirror.blockCount()))
        .add("known_voxels", static_cast<std::uint64_t>(mirror.knownVoxelCount()))
        .add("resolution_m", mirror.resolution());
    io.out << line.str() << std::endl;
  } else {
    io.out << "wrote " << o.out << ": map version " << mirror.version() << ", " << mirror.knownVoxelCount()
           << " known voxels at " << mirror.resolution() << " m" << std::endl;
  }
  return kExitOk;
}

int runCloudCommand(const CloudOptions& o, const CommandIo& io) {
  if (!checkExtension(io, "cloud", o.out, {".ply"}, ".ply")) return kExitUsage;
  auto conn = openConnection(o.conn, io, "cloud");
  if (!conn.client) return conn.exit_code;
  detail::ProgressLine line(io, o.progress, "cloud", "points");
  auto cloud = conn.client->cloud([&](std::uint64_t n, std::uint64_t total) { line.update(n, total); });
  line.finish();
  if (!cloud) {
    detail::report(io, "cloud", cloud.error().message);
    return conn.client->broken() ? kExitUsage : kExitRefused;
  }
  if (Status s = writePly(o.out, *cloud); !s.ok()) {
    detail::report(io, "cloud", s.error().message);
    return kExitUsage;
  }
  const bool normals = hasNormals(*cloud);
  if (o.json) {
    JsonLine out;
    out.add("out", o.out).add("points", static_cast<std::uint64_t>(cloud->size())).add("normals", normals);
    io.out << out.str() << std::endl;
  } else {
    io.out << "wrote " << o.out << ": " << cloud->size() << " points" << (normals ? " with normals" : "") << std::endl;
  }
  return kExitOk;
}

int runTopViewCommand(const TopViewOptions& o, const CommandIo& io) {
  if (!checkExtension(io, "topview", o.out, {".png"}, ".png")) return kExitUsage;
  TopViewConfig config;
  config.px_per_m = o.px_per_m;
  config.max_side_px = o.max_side_px;
  if (Status s = config.validate(); !s.ok()) {
    detail::report(io, "topview", s.error().message);
    return kExitUsage;
  }
  auto conn = openConnection(o.conn, io, "topview");
  if (!conn.client) return conn.exit_code;
  api::MapMirror mirror;
  if (int rc = fetchMap(*conn.client, mirror, io, "topview", o.progress); rc != kExitOk) return rc;
  auto view = renderTopView(mirror, config);
  if (!view) {
    // An empty map is what the server holds, not a usage error.
    detail::report(io, "topview", view.error().message);
    return mirror.knownVoxelCount() == 0 ? kExitRefused : kExitUsage;
  }
  if (Status s = codec::writePng(o.out, view->image); !s.ok()) {
    detail::report(io, "topview", s.error().message);
    return kExitUsage;
  }
  if (o.json) {
    JsonLine line;
    line.add("out", o.out)
        .add("width_px", view->image.width)
        .add("height_px", view->image.height)
        .add("px_per_m", view->px_per_m)
        .add("x_min_m", view->x_min_m)
        .add("y_max_m", view->y_max_m)
        .add("z_min_m", view->z_min_m)
        .add("z_max_m", view->z_max_m)
        .add("map_version", static_cast<std::uint64_t>(mirror.version()));
    io.out << line.str() << std::endl;
  } else {
    io.out << "wrote " << o.out << ": " << view->image.width << " x " << view->image.height << " px at "
           << view->px_per_m << " px/m, x from " << view->x_min_m << " m, y up to " << view->y_max_m << " m, heights "
           << view->z_min_m << " .. " << view->z_max_m << " m (map version " << mirror.version() << ")" << std::endl;
  }
  return kExitOk;
}

}  // namespace vog::client
