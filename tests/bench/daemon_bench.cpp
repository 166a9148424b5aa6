// vog-bench daemon: the vogd executable on a simulated mission with topside clients attached, as on a
// vehicle: N observers subscribed to every stream and one operator polling status and config and
// fetching map deltas, while the planner publishes waypoints. Reports the waypoint latency from the
// planner's hand-over (the daemon's wall clock in each waypoint) to each observer's receipt, losses,
// the time to fetch the whole map at the end, and the daemon's own RSS and CPU (from /proc, sampled
// every second; 100 % = one core), at its peak and at the mission's end; then restarts vogd on the
// mission's folder and reports its RSS once every submap has been read back (a resumed mission).
// vogd and the clients share this machine's cores.
#include "bench_cli.hpp"
#include "bench_registry.hpp"
#include "proc_sample.hpp"
#include "subprocess.hpp"

#include "vog/client/api_client.hpp"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
std::int64_t unixNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

VOG_BENCH_COMMAND(daemon, "vogd on a simulated mission with 32 observers + 1 operator: latency, losses, RSS, CPU") {
  std::string vogd = (fs::read_symlink("/proc/self/exe").parent_path() / "vogd").string();
  std::string scene = "config/scenes/pilings.yaml";
  double speedup = 20.0;
  int observers = 32, submaps = 30;
  double max_s = 300.0;
  bool json = false;
  CLI::App app{"vog-bench daemon"};
  app.add_option("--vogd", vogd, "the vogd executable (default: next to vog-bench)");
  app.add_option("--scene", scene, "scene of the simulated mission");
  app.add_option("--speedup", speedup, "simulated seconds per wall second")->check(CLI::Range(0.1, 1000.0));
  app.add_option("--observers", observers, "observer clients")->check(CLI::Range(0, 60));
  app.add_option("--submaps", submaps, "submap budget of the mission")->check(CLI::Range(1, 1000));
  app.add_option("--max-s", max_s, "wall-time limit, s")->check(CLI::Range(1.0, 36000.0));
  app.add_flag("--json", json, "print JSON (the only output format)");
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;
  auto fail = [](const std::string& message) {
    std::cerr << "daemon bench: " << message << "\n";
    return 1;
  };
  char tmpl[] = "/tmp/vog-bench-daemon-XXXXXX";
  if (::mkdtemp(tmpl) == nullptr) return fail("cannot create a temporary folder");
  const fs::path dir = tmpl;
  std::ofstream(dir / "secret") << vog::bench::kOperatorSecret << "\n";
  fs::permissions(dir / "secret", fs::perms::owner_read | fs::perms::owner_write);  // vogd refuses a readable one
  fs::permissions(dir / "secret", fs::perms::owner_read | fs::perms::owner_write);
  std::ofstream(dir / "vogd.yaml") << "source: sim\nsim:\n  scene: " << fs::absolute(scene).string()
                                   << "\n  seed: 1\n  speedup: " << speedup
                                   << "\nmission:\n  start_on_launch: true\n  max_submaps: " << submaps
                                   << "\n  box_min_m: [-6, -4, -4]\n  box_max_m: [6, 4, 0]\n"
                                      "api:\n  port: 0\n  max_clients_per_peer: 64\n  secret_file: "
                                   << (dir / "secret").string() << "\n"
                                   << "log:\n  level: warning\n";
  const std::vector<std::string> command = {vogd,
                                            "--config",
                                            (dir / "vogd.yaml").string(),
                                            "--mission-dir",
                                            (dir / "mission").string(),
                                            "--port-file",
                                            (dir / "port").string()};
  // Waits for a started vogd to listen and returns its port (0 on failure). A resumed vogd listens
  // once it has read its mission back.
  auto start = [&](vog::test::Subprocess& process, double timeout_s) -> std::uint16_t {
    if (!process.started()) return 0;
    for (int i = 0; i < static_cast<int>(timeout_s * 50.0); ++i) {
      std::ifstream in(dir / "port");
      int p = 0;
      if (in >> p) return static_cast<std::uint16_t>(p);
      if (!process.running()) return 0;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return 0;
  };
  vog::test::Subprocess daemon(command, {}, dir / "vogd.log");
  const std::uint16_t port = start(daemon, 6.0);
  if (port == 0) return fail("vogd did not start listening: " + vog::test::readTextFile(dir / "vogd.log"));

  std::atomic<bool> stop{false};
  std::mutex mutex;
  std::vector<double> latency_ms;
  std::vector<std::uint64_t> received(static_cast<std::size_t>(observers), 0),
      dropped(static_cast<std::size_t>(observers), 0);
  std::vector<std::string> errors;
  std::vector<std::thread> threads;
  for (int i = 0; i < observers; ++i) {
    threads.emplace_back([&, i] {
      auto c = vog::client::ApiClient::connect("127.0.0.1", port);
      if (!c || !(*c)->subscribe({true, true, true})) {
        const std::lock_guard lock(mutex);
        errors.push_back("observer " + std::to_string(i) + " could not connect and subscribe");
        return;
      }
      while (!stop) {
        auto m = (*c)->nextStream(std::chrono::milliseconds(200));
        if (!m) continue;  // timeout
        if (const auto* w = std::get_if<vog::api::Waypoint>(&*m)) {
          const double ms = 1e-6 * static_cast<double>(unixNs() - w->published_unix_ns);
          const std::lock_guard lock(mutex);
          latency_ms.push_back(ms);
          ++received[static_cast<std::size_t>(i)];
          dropped[static_cast<std::size_t>(i)] = w->dropped;
        }
      }
    });
  }
  // The operator: status and config once a second, the map as deltas every 5 s.
  std::string final_state;
  std::uint32_t n_submaps = 0;
  std::uint64_t published = 0;
  double delta_fetch_s_max = 0.0;
  vog::api::MapMirror mirror;
  auto op = vog::client::ApiClient::connect("127.0.0.1", port);
  if (!op) return fail("operator: " + op.error().message);
  if (auto r = (*op)->authenticate(vog::bench::kOperatorSecret); !r)
    return fail("operator authentication: " + r.error().message);
  std::vector<vog::bench::ProcSample> samples;
  const auto t0 = Clock::now();
  int tick = 0;
  while (std::chrono::duration<double>(Clock::now() - t0).count() < max_s) {
    std::this_thread::sleep_for(std::chrono::seconds(1));
    ++tick;
    if (auto s = vog::bench::sampleProc(daemon.pid())) samples.push_back(*s);
    auto st = (*op)->status();
    if (!st) return fail("operator status: " + st.error().message);
    if (!(*op)->configText()) return fail("operator config read failed");
    if (tick % 5 == 0) {
      const auto f0 = Clock::now();
      if (auto r = (*op)->fetchMap(mirror); !r) return fail("map delta: " + r.error().message);
      delta_fetch_s_max = std::max(delta_fetch_s_max, std::chrono::duration<double>(Clock::now() - f0).count());
    }
    final_state = vog::api::toString(st->mission_state);
    n_submaps = st->n_submaps;
    if (st->mission_state == vog::api::MissionState::kComplete || st->mission_state == vog::api::MissionState::kAborted)
      break;
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  // The whole map from scratch, as a newly connected topside view would fetch it.
  vog::api::MapMirror fresh;
  const auto f0 = Clock::now();
  if (auto r = (*op)->fetchMap(fresh); !r) return fail("map snapshot: " + r.error().message);
  const double snapshot_s = std::chrono::duration<double>(Clock::now() - f0).count();
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the last waypoints reach everyone
  stop = true;
  for (auto& t : threads) t.join();
  if (auto s = vog::bench::sampleProc(daemon.pid())) samples.push_back(*s);
  daemon.signal(SIGTERM);
  const int exit_status = daemon.wait(5.0);

  // The same mission resumed from its folder: vogd reads every submap back, then waits.
  fs::remove(dir / "port");
  double resumed_rss_mb = 0.0, resume_s = 0.0;
  std::uint32_t resumed_submaps = 0;
  {
    vog::test::Subprocess again(command, {}, dir / "vogd-resumed.log");
    const auto r0 = Clock::now();
    const std::uint16_t again_port = start(again, 600.0);
    if (again_port == 0) return fail("vogd did not resume: " + vog::test::readTextFile(dir / "vogd-resumed.log"));
    auto c = vog::client::ApiClient::connect("127.0.0.1", again_port);
    if (!c) return fail("resumed vogd: " + c.error().message);
    for (int i = 0; i < 600 && resumed_submaps < n_submaps; ++i) {
      auto st = (*c)->status();
      if (!st) return fail("resumed vogd status: " + st.error().message);
      resumed_submaps = st->n_submaps;
      if (resumed_submaps < n_submaps) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    resume_s = std::chrono::duration<double>(Clock::now() - r0).count();
    std::this_thread::sleep_for(std::chrono::seconds(2));  // the merge of what was read back settles
    if (auto s = vog::bench::sampleProc(again.pid())) resumed_rss_mb = s->rss_mb;
    again.signal(SIGTERM);
    again.wait(5.0);
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
  if (!errors.empty()) return fail(errors.front());
  if (samples.size() < 2) return fail("no /proc samples of vogd");

  std::vector<double> cpu_pct;
  for (std::size_t i = 1; i < samples.size(); ++i)
    cpu_pct.push_back(100.0 * (samples[i].cpu_s - samples[i - 1].cpu_s) /
                      std::max(1e-3, samples[i].t_s - samples[i - 1].t_s));
  double rss_sum = 0.0;
  for (const vog::bench::ProcSample& s : samples) rss_sum += s.rss_mb;
  for (std::uint64_t r : received) published = std::max(published, r);
  std::uint64_t min_received = published, drops = 0;
  for (std::size_t i = 0; i < received.size(); ++i) {
    min_received = std::min(min_received, received[i]);
    drops += dropped[i];
  }
  vog::bench::JsonObject out;
  out.add("mission_state", final_state);
  out.add("wall_s", wall_s);
  out.add("observers", static_cast<std::int64_t>(observers));
  out.add("waypoints", static_cast<std::int64_t>(published));
  out.add("waypoints_min_received", static_cast<std::int64_t>(min_received));
  out.add("waypoint_drops", static_cast<std::int64_t>(drops));
  out.add("latency_ms_p50", latency_ms.empty() ? 0.0 : vog::bench::median(latency_ms));
  out.add("latency_ms_p99", latency_ms.empty() ? 0.0 : vog::bench::percentile(latency_ms, 0.99));
  out.add("latency_ms_max", latency_ms.empty() ? 0.0 : vog::bench::percentile(latency_ms, 1.0));
  out.add("map_known_voxels", static_cast<std::int64_t>(fresh.knownVoxelCount()));
  out.add("map_fetch_s", snapshot_s);
  out.add("map_delta_fetch_s_max", delta_fetch_s_max);
  out.add("submaps", static_cast<std::int64_t>(n_submaps));
  out.add("vogd_rss_mb_peak", samples.back().hwm_mb);
  out.add("vogd_rss_mb_end", samples.back().rss_mb);
  out.add("vogd_rss_mb_resumed", resumed_rss_mb);
  out.add("resumed_submaps", static_cast<std::int64_t>(resumed_submaps));
  out.add("resume_s", resume_s);
  out.add("vogd_rss_mb_mean", rss_sum / static_cast<double>(samples.size()));
  out.add("vogd_cpu_pct_mean", 100.0 * (samples.back().cpu_s - samples.front().cpu_s) /
                                   std::max(1e-3, samples.back().t_s - samples.front().t_s));
  out.add("vogd_cpu_pct_p95", vog::bench::percentile(cpu_pct, 0.95));
  out.add("vogd_exit_status", static_cast<std::int64_t>(exit_status));
  std::cout << out.str();
  return exit_status == 0 ? 0 : 1;
}
