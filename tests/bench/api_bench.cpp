// vog-bench api: vogd's API on loopback. 32 observers subscribed to every stream and 1 operator
// sending commands while waypoints and poses are published: waypoint latency from publishWaypoint()
// to the client's receipt (p50/p99/max; target p99 <= 10 ms). Then a snapshot of a merged
// map of about one million known voxels fetched from version 0 by one client (target <= 1 s).
// Server and clients share this process (and its 2 cores); RSS and CPU are the whole process's.
// With --stalled-readers: 64 observers each ask for the whole map 16 times and never read (a map of
// about 20 MB encoded, as a 157-submap mission's) while one client asks for the status: the RSS
// growth over idle (target <= 300 MB) and the status latency (p50/p99; target p99 < 100 ms).
#include "bench_cli.hpp"
#include "bench_registry.hpp"

#include "vog/api/api_server.hpp"
#include "vog/api/framing.hpp"
#include "vog/client/api_client.hpp"

#include <CLI/CLI.hpp>
#include <asio.hpp>
#include <octomap/OcTree.h>

#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <thread>

namespace {

using namespace vog;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

std::int64_t nowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

// A cube of side^3 voxels at the thesis resolution: every fifth voxel occupied, the rest free, so
// every block is fully known (the worst case for a snapshot: 2 KB of values per block).
Result<std::shared_ptr<const map::MergedMap>> buildCubeMap(int side) {
  const map::GridConfig config;
  auto tree = std::make_unique<octomap::OcTree>(config.resolution_m);
  const double r = config.resolution_m;
  for (int x = 0; x < side; ++x) {
    for (int y = 0; y < side; ++y) {
      for (int z = 0; z < side; ++z) {
        const bool occupied = (x * 7 + y * 13 + z * 17) % 5 == 0;
        tree->updateNode(octomap::point3d(static_cast<float>((x + 0.5) * r), static_cast<float>((y + 0.5) * r),
                                          static_cast<float>((z + 0.5) * r)),
                         occupied, true);
      }
    }
  }
  tree->updateInnerOccupancy();
  auto grid = map::LocalGrid::fromTree(config, std::move(tree));
  if (!grid) return grid.error();
  auto merged = map::MergedMap::create(config);
  if (!merged) return merged.error();
  map::SubmapEntry entry;
  entry.id = 0;
  entry.grid = std::shared_ptr<const map::LocalGrid>(std::move(*grid));
  if (Status s = (*merged)->add(entry); !s.ok()) return s.error();
  return (*merged)->snapshot();
}

class BenchBackend final : public api::ApiBackend {
 public:
  explicit BenchBackend(std::shared_ptr<const map::MergedMap> map) : map_(std::move(map)) {}
  api::StatusReport status() const override {
    api::StatusReport s;
    s.mission_state = state_.load();
    s.devices = {{"dvl", api::DeviceState::kOk, "", 0, 100, 0}, {"sonar", api::DeviceState::kOk, "", 0, 50, 0}};
    s.map_version = map_->version();
    return s;
  }
  std::shared_ptr<const map::MergedMap> mapSnapshot() const override { return map_; }
  std::vector<api::SubmapInfo> submaps() const override { return {}; }
  // No pose graph and no grids: these clients never ask for them.
  std::shared_ptr<const api::GraphState> graph() const override { return nullptr; }
  std::shared_ptr<const map::LocalGrid> submapGrid(std::uint32_t) const override { return nullptr; }
  std::shared_ptr<const api::ServedCloud> cloud() const override { return nullptr; }
  Result<api::MissionState> command(const api::MissionCommand& c) override {
    state_ = c.kind == api::MissionCommand::Kind::kPause ? api::MissionState::kPaused : api::MissionState::kExploring;
    return state_.load();
  }
  std::string configText() const override { return "api: {}\n"; }

 private:
  std::shared_ptr<const map::MergedMap> map_;
  std::atomic<api::MissionState> state_{api::MissionState::kExploring};
};

double rssMb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0.0;
}

// The resident set now (VmRSS), MB.
double rssNowMb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0.0;
}

double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

// Observers that request the whole map `requests` times each and never read, and one client asking
// for the status every 20 ms for `duration_s`.
// The server on loopback at a free port; every client comes from one address, so the per-address cap
// is the server's.
Result<std::pair<std::unique_ptr<api::ApiServer>, std::uint16_t>> serveOnLoopback(asio::io_context& io,
                                                                                  api::ApiBackend& backend,
                                                                                  api::ApiServerConfig config) {
  config.max_clients_per_peer = config.max_clients;
  auto server = api::ApiServer::create(io, backend, config);
  if (!server) return server.error();
  const auto port = (*server)->listen("127.0.0.1", 0);
  if (!port) return port.error();
  return std::make_pair(std::move(server).value(), *port);
}

int stalledReaders(std::shared_ptr<const map::MergedMap> map, int observers, int requests, double duration_s) {
  BenchBackend backend(map);
  asio::io_context io;
  api::ApiServerConfig config;
  config.dispatch.operator_secret = vog::bench::kOperatorSecret;
  config.max_clients = static_cast<std::size_t>(observers) + 8;
  config.max_in_flight = std::max<std::size_t>(config.max_in_flight, static_cast<std::size_t>(requests));
  config.max_queued_responses = std::max(config.max_queued_responses, config.max_in_flight);
  auto served = serveOnLoopback(io, backend, config);
  if (!served) {
    std::fprintf(stderr, "vog-bench api: %s\n", served.error().message.c_str());
    return 1;
  }
  const std::unique_ptr<api::ApiServer>& server = served->first;
  const std::uint16_t port = served->second;
  std::thread io_thread([&] { io.run(); });
  auto status_client = client::ApiClient::connect("127.0.0.1", port);
  if (!status_client || !(*status_client)->status().ok()) {
    std::fprintf(stderr, "vog-bench api: the status client cannot connect\n");
    return 1;
  }
  const double rss_idle_mb = rssNowMb();

  std::string bytes;
  for (int r = 1; r <= requests; ++r) {
    v1::Envelope e;
    e.set_request_id(static_cast<std::uint64_t>(r));
    e.mutable_get_map()->set_since_version(0);
    bytes += api::encodeFrame(e).value();
  }
  std::vector<std::unique_ptr<client::ApiClient>> stalled;
  int failures = 0;
  for (int i = 0; i < observers; ++i) {
    auto c = client::ApiClient::connect("127.0.0.1", port);
    if (!c || !(*c)->sendRaw(bytes).ok()) {
      ++failures;
      continue;
    }
    stalled.push_back(std::move(*c));
  }

  std::vector<double> status_ms;
  double rss_peak_mb = rssNowMb();
  const bench::Stopwatch run;
  while (run.seconds() < duration_s) {
    const bench::Stopwatch sw;
    if (!(*status_client)->status().ok()) ++failures;
    status_ms.push_back(sw.seconds() * 1e3);
    rss_peak_mb = std::max(rss_peak_mb, rssNowMb());
    std::this_thread::sleep_for(20ms);
  }
  const api::ApiServerStats stats = server->stats();
  stalled.clear();
  server->stop();
  io.stop();
  io_thread.join();

  bench::JsonObject out;
  out.add("mode", std::string("stalled-readers"));
  out.add("stalled_observers", observers);
  out.add("map_requests_each", requests);
  out.add("map_blocks", static_cast<std::int64_t>(map->blockCount()));
  out.add("map_encoded_mb", static_cast<double>(map->blockCount()) * 2150.0 / 1e6);
  out.add("client_failures", failures);
  out.add("status_requests", static_cast<std::int64_t>(status_ms.size()));
  out.add("status_latency_p50_ms", bench::percentile(status_ms, 0.5));
  out.add("status_latency_p99_ms", bench::percentile(status_ms, 0.99));
  out.add("status_latency_p99_target_ms", 100.0);
  out.add("rss_idle_mb", rss_idle_mb);
  out.add("rss_peak_mb", rss_peak_mb);
  out.add("rss_growth_mb", rss_peak_mb - rss_idle_mb);
  out.add("rss_growth_target_mb", 300.0);
  out.add("server_queued_mb", static_cast<double>(stats.queued_bytes) / 1e6);
  out.add("server_max_session_queued_mb", static_cast<double>(stats.max_session_queued_bytes) / 1e6);
  out.add("server_max_queued_mb_per_client", static_cast<double>(config.max_queued_bytes) / 1e6);
  out.add("server_write_timeout_disconnects", static_cast<std::int64_t>(stats.slow_disconnects));
  out.add("note", std::string("server and all clients in one process on loopback; the clients never read"));
  std::printf("%s\n", out.str().c_str());
  return failures == 0 ? 0 : 1;
}

}  // namespace

VOG_BENCH_COMMAND(api, "API on loopback: waypoint latency to 32 observers + 1 operator, 1M-voxel snapshot time") {
  int observers = 32;
  int waypoints = 2000;
  double rate_hz = 200.0;
  int side = 100;
  bool json = false;
  bool stalled_readers = false;
  double duration_s = 5.0;
  CLI::App app{"vog-bench api"};
  app.add_option("--observers", observers, "observer clients subscribed to every stream")->check(CLI::Range(1, 200));
  app.add_option("--waypoints", waypoints, "waypoints published")->check(CLI::Range(10, 1000000));
  app.add_option("--rate", rate_hz, "waypoints (and poses) published per second")->check(CLI::Range(1.0, 100000.0));
  app.add_option("--side", side, "the snapshot map is a cube of side^3 voxels")->check(CLI::Range(8, 400));
  app.add_flag("--json", json, "print JSON (the only output format)");
  app.add_flag("--stalled-readers", stalled_readers,
               "observers request the whole map 16 times each and never read (--observers, default 64; "
               "--side, default 170: about 20 MB encoded); RSS growth and status latency");
  app.add_option("--duration", duration_s, "--stalled-readers: seconds of status requests")
      ->check(CLI::Range(1.0, 600.0));
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;
  if (stalled_readers) {
    if (app.count("--observers") == 0) observers = 64;
    if (app.count("--side") == 0) side = 170;
  }

  const bench::Stopwatch build_clock;
  auto map = buildCubeMap(side);
  if (!map) {
    std::fprintf(stderr, "vog-bench api: %s\n", map.error().message.c_str());
    return 1;
  }
  std::fprintf(stderr, "built a map of %zu known voxels in %zu blocks in %.1f s\n", (*map)->knownVoxelCount(),
               (*map)->blockCount(), build_clock.seconds());
  if (stalled_readers) return stalledReaders(*map, observers, 16, duration_s);
  BenchBackend backend(*map);

  asio::io_context io;
  api::ApiServerConfig config;
  config.dispatch.operator_secret = vog::bench::kOperatorSecret;
  config.max_clients = static_cast<std::size_t>(observers) + 8;
  auto served = serveOnLoopback(io, backend, config);
  if (!served) {
    std::fprintf(stderr, "vog-bench api: %s\n", served.error().message.c_str());
    return 1;
  }
  const std::unique_ptr<api::ApiServer>& server = served->first;
  const std::uint16_t port = served->second;
  std::thread io_thread([&] { io.run(); });
  const double cpu0 = cpuSeconds();

  // Observers: each records the latency of every waypoint it receives.
  std::mutex mutex;
  std::vector<double> latencies_ms;
  std::atomic<int> ready{0};
  std::atomic<std::uint64_t> received{0};
  std::atomic<std::uint64_t> client_drops{0};
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int i = 0; i < observers; ++i) {
    threads.emplace_back([&] {
      auto c = client::ApiClient::connect("127.0.0.1", port);
      if (!c || !(*c)->subscribe({true, true, true}).ok()) {
        ++failures;
        ++ready;
        return;
      }
      ++ready;
      std::vector<double> mine;
      mine.reserve(static_cast<std::size_t>(waypoints));
      std::uint64_t last_dropped = 0;
      for (;;) {
        auto m = (*c)->nextStream(3s);
        if (!m) break;  // the publisher is done
        if (const auto* w = std::get_if<api::Waypoint>(&*m)) {
          mine.push_back(static_cast<double>(nowNs() - w->stamp_ns) * 1e-6);
          last_dropped = w->dropped;
          if (w->seq == static_cast<std::uint64_t>(waypoints)) break;
        }
      }
      received += mine.size();
      client_drops += last_dropped;
      std::lock_guard lock(mutex);
      latencies_ms.insert(latencies_ms.end(), mine.begin(), mine.end());
    });
  }
  // The operator: authenticated, pausing and resuming and reading status throughout.
  std::atomic<bool> publishing{true};
  std::atomic<int> commands{0};
  threads.emplace_back([&] {
    auto c = client::ApiClient::connect("127.0.0.1", port);
    if (!c || !(*c)->authenticate(vog::bench::kOperatorSecret).ok()) {
      ++failures;
      ++ready;
      return;
    }
    ++ready;
    bool pause = true;
    while (publishing) {
      api::MissionCommand cmd;
      cmd.kind = pause ? api::MissionCommand::Kind::kPause : api::MissionCommand::Kind::kResume;
      pause = !pause;
      if (!(*c)->command(cmd).ok() || !(*c)->status().ok()) {
        ++failures;
        return;
      }
      ++commands;
      std::this_thread::sleep_for(20ms);
    }
  });
  while (ready < observers + 1) std::this_thread::sleep_for(1ms);

  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate_hz));
  Clock::time_point next = Clock::now();
  for (int i = 0; i < waypoints; ++i) {
    std::this_thread::sleep_until(next);
    next += period;
    api::Waypoint w;
    w.stamp_ns = nowNs();
    w.T_world_target = geometry::poseFromXyzRpy(0.01 * i, 1.0, -2.0, 0.0, 0.0, 0.001 * i);
    w.speed_mps = 0.25;
    server->publishWaypoint(w);
    api::PoseUpdate p;
    p.stamp_ns = w.stamp_ns;
    p.T_world_vehicle = w.T_world_target;
    server->publishPose(p);
    if (i % 50 == 0) server->publishStatus(backend.status());
  }
  publishing = false;
  for (auto& t : threads) t.join();
  const double stream_cpu_s = cpuSeconds() - cpu0;

  // Snapshot: a full map from version 0, three times.
  std::vector<double> snapshot_s;
  std::size_t voxels = 0;
  for (int rep = 0; rep < 3; ++rep) {
    auto c = client::ApiClient::connect("127.0.0.1", port);
    if (!c) {
      std::fprintf(stderr, "vog-bench api: %s\n", c.error().message.c_str());
      return 1;
    }
    api::MapMirror mirror;
    const bench::Stopwatch sw;
    if (Status s = (*c)->fetchMap(mirror); !s.ok()) {
      std::fprintf(stderr, "vog-bench api: map fetch failed: %s\n", s.error().message.c_str());
      return 1;
    }
    snapshot_s.push_back(sw.seconds());
    voxels = 0;
    (*map)->forEachKnown(
        [&](const map::VoxelKey& k, const map::VoxelValue& v) { voxels += (mirror.at(k).status == v.status) ? 1 : 0; });
    if (voxels != (*map)->knownVoxelCount() || mirror.blockCount() != (*map)->blockCount()) {
      std::fprintf(stderr, "vog-bench api: the fetched map differs from the server's\n");
      return 1;
    }
  }
  const api::ApiServerStats stats = server->stats();
  server->stop();
  io.stop();
  io_thread.join();

  bench::JsonObject out;
  out.add("observers", observers);
  out.add("operator_commands", commands.load());
  out.add("client_failures", failures.load());
  out.add("waypoints_published", waypoints);
  out.add("publish_rate_hz", rate_hz);
  out.add("waypoints_received", static_cast<std::int64_t>(received.load()));
  out.add("waypoints_expected", static_cast<std::int64_t>(waypoints) * observers);
  out.add("waypoint_drops_server", static_cast<std::int64_t>(stats.waypoint_drops));
  out.add("pose_status_coalesced_server", static_cast<std::int64_t>(stats.stream_drops - stats.waypoint_drops));
  out.add("waypoint_latency_p50_ms", bench::percentile(latencies_ms, 0.5));
  out.add("waypoint_latency_p99_ms", bench::percentile(latencies_ms, 0.99));
  out.add("waypoint_latency_max_ms", bench::percentile(latencies_ms, 1.0));
  out.add("waypoint_latency_p99_target_ms", 10.0);
  out.add("snapshot_known_voxels", static_cast<std::int64_t>(voxels));
  out.add("snapshot_blocks", static_cast<std::int64_t>((*map)->blockCount()));
  out.add("snapshot_s_median", bench::median(snapshot_s));
  out.add("snapshot_target_s", 1.0);
  out.add("process_cpu_s_streaming", stream_cpu_s);
  out.add("process_rss_peak_mb", rssMb());
  out.add("note", std::string("server and all clients in one process on loopback"));
  std::printf("%s\n", out.str().c_str());
  return failures.load() == 0 ? 0 : 1;
}
