// vog-bench console: what the topside link carries for a whole simulated mission, three ways at once
// against one vogd: the mirror (every closed submap fetched once with GetSubmap, base poses from the
// graph stream), GetMap deltas polled every --poll-s simulated seconds, and the whole map fetched at the
// same rate. Per graph update that moved submaps, its bytes on the wire per moved submap. Alongside,
// the vog-console executable follows the mission (its CPU and RSS from /proc, sampled every second),
// and with --page-measure a headless browser on its page reports the latency from vogd publishing a
// pose to the page drawing it, and the page's longest frame.
#include "bench_cli.hpp"
#include "bench_registry.hpp"
#include "proc_sample.hpp"
#include "subprocess.hpp"

#include "vog/api/map_delta.hpp"
#include "vog/client/api_client.hpp"
#include "vog/console/submap_mirror.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <atomic>
#include <csignal>
#include <fstream>
#include <iostream>
#include <mutex>
#include <thread>

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// Waits for a child to write its port file; 0 when it does not (or exits first).
std::uint16_t waitForPort(vog::test::Subprocess& process, const fs::path& file, double timeout_s) {
  if (!process.started()) return 0;
  for (int i = 0; i < static_cast<int>(timeout_s * 50.0); ++i) {
    std::ifstream in(file);
    int p = 0;
    if (in >> p && p > 0) return static_cast<std::uint16_t>(p);
    if (!process.running()) return 0;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return 0;
}

std::size_t wireBytes(const vog::api::GraphUpdate& u) {
  vog::v1::Envelope e;
  vog::api::toProto(u, *e.mutable_graph_update());
  return 4 + e.ByteSizeLong();  // the frame's length prefix and the envelope
}

}  // namespace

VOG_BENCH_COMMAND(console,
                  "topside link bytes: submap mirror vs map deltas vs full maps; vog-console CPU/RSS/latency") {
  const fs::path bin = fs::read_symlink("/proc/self/exe").parent_path();
  std::string vogd = (bin / "vogd").string();
  std::string console = (bin / "vog-console").string();
  std::string scene = "config/scenes/pilings.yaml";
  std::string page_measure;
  int seed = 1;
  double speedup = 5.0, poll_s = 2.0, max_s = 3600.0;
  int submaps = 0;
  bool json = false;
  CLI::App app{"vog-bench console"};
  app.add_option("--vogd", vogd, "the vogd executable (default: next to vog-bench)");
  app.add_option("--console", console, "the vog-console executable (default: next to vog-bench)");
  app.add_option("--scene", scene, "scene of the simulated mission");
  app.add_option("--seed", seed, "simulator seed");
  app.add_option("--speedup", speedup, "simulated seconds per wall second")->check(CLI::Range(0.5, 100.0));
  app.add_option("--poll-s", poll_s, "simulated seconds between GetMap polls")->check(CLI::Range(0.1, 600.0));
  app.add_option("--submaps", submaps, "submap budget (0: the mission's own end)")->check(CLI::Range(0, 10000));
  app.add_option("--max-s", max_s, "wall-time limit, s")->check(CLI::Range(1.0, 36000.0));
  app.add_option("--page-measure", page_measure,
                 "node script that opens the console's page in headless Chromium and prints its figures as JSON "
                 "(tests/console/measure_page.mjs)");
  app.add_flag("--json", json, "print JSON (the only output format)");
  if (const auto exit_code = vog::bench::parseArgs(app, args)) return *exit_code;
  auto fail = [](const std::string& message) {
    std::cerr << "console bench: " << message << "\n";
    return 1;
  };
  char tmpl[] = "/tmp/vog-bench-console-XXXXXX";
  if (::mkdtemp(tmpl) == nullptr) return fail("cannot create a temporary folder");
  const fs::path dir = tmpl;
  {
    std::ofstream cfg(dir / "vogd.yaml");
    cfg << "source: sim\nsim:\n  scene: " << fs::absolute(scene).string() << "\n  seed: " << seed
        << "\n  speedup: " << speedup << "\nmission:\n  start_on_launch: true\n";
    if (submaps > 0) cfg << "  max_submaps: " << submaps << "\n";
    cfg << "  box_min_m: [-6, -4, -4]\n  box_max_m: [6, 4, 0]\napi:\n  port: 0\nlog:\n  level: warning\n";
  }
  vog::test::Subprocess daemon({vogd, "--config", (dir / "vogd.yaml").string(), "--mission-dir",
                                (dir / "mission").string(), "--port-file", (dir / "port").string()},
                               {}, dir / "vogd.log");
  const std::uint16_t port = waitForPort(daemon, dir / "port", 10.0);
  if (port == 0) return fail("vogd did not start listening: " + vog::test::readTextFile(dir / "vogd.log"));
  vog::test::Subprocess viewer({console, "--port", std::to_string(port), "--listen", "127.0.0.1:0", "--port-file",
                                (dir / "console-port").string()},
                               {}, dir / "console.log");
  const std::uint16_t web_port = waitForPort(viewer, dir / "console-port", 10.0);
  if (web_port == 0) return fail("vog-console did not start: " + vog::test::readTextFile(dir / "console.log"));
  std::unique_ptr<vog::test::Subprocess> page;
  if (!page_measure.empty()) {
    page = std::make_unique<vog::test::Subprocess>(
        std::vector<std::string>{"/usr/bin/env", "node", page_measure, "--url",
                                 "http://127.0.0.1:" + std::to_string(web_port) + "/", "--json",
                                 (dir / "page.json").string()},
        std::vector<std::string>{}, dir / "page.log");
    if (!page->started()) return fail("cannot start " + page_measure);
  }

  std::atomic<bool> stop{false};
  std::mutex mutex;
  std::vector<std::string> errors;
  const auto error = [&](const std::string& e) {
    const std::lock_guard lock(mutex);
    errors.push_back(e);
  };
  // The mirror: graph stream + each closed submap once.
  std::uint64_t mirror_bytes = 0, submap_bytes = 0, graph_bytes = 0, moved_submaps = 0, graph_updates = 0;
  std::vector<double> bytes_per_moved;
  std::uint64_t mirror_graph_version = 0;
  std::size_t mirror_submaps = 0;
  std::thread mirror_thread([&] {
    auto c = vog::client::ApiClient::connect("127.0.0.1", port);
    if (!c || !(*c)->subscribe({false, false, false, true})) return error("mirror: cannot connect and subscribe");
    vog::console::SubmapMirror mirror;
    while (!stop) {
      auto m = (*c)->nextStream(std::chrono::milliseconds(200));
      if (!m) {
        if (!(*c)->timedOut()) {
          return error("mirror: " + m.error().message);
        }
        continue;
      }
      const auto* u = std::get_if<vog::api::GraphUpdate>(&*m);
      if (u == nullptr) continue;
      const std::size_t wire = wireBytes(*u);
      const std::size_t moved = u->moved.size();
      if (auto st = mirror.applyGraph(*u); !st) return error("mirror: " + st.error().message);
      const std::uint64_t before = (*c)->bytesReceived();
      for (const std::uint32_t id : mirror.missingGrids()) {
        auto g = (*c)->fetchSubmap(id);
        if (!g) return error("mirror: submap " + std::to_string(id) + ": " + g.error().message);
        if (auto st = mirror.addGrid(id, std::move(g).value()); !st) return error("mirror: " + st.error().message);
      }
      const std::lock_guard lock(mutex);
      submap_bytes += (*c)->bytesReceived() - before;
      graph_bytes += wire;
      ++graph_updates;
      if (!u->full && moved > 0) {
        moved_submaps += moved;
        bytes_per_moved.push_back(static_cast<double>(wire) / static_cast<double>(moved));
      }
      mirror_bytes = (*c)->bytesReceived();
      mirror_graph_version = mirror.graph().version;
      mirror_submaps = mirror.gridCount();
    }
  });
  // GetMap every poll: deltas (one client) and the whole map (another).
  std::uint64_t delta_bytes = 0, full_bytes = 0, polls = 0;
  const auto poll_period = std::chrono::duration<double>(poll_s / speedup);
  std::thread poll_thread([&] {
    auto d = vog::client::ApiClient::connect("127.0.0.1", port);
    auto f = vog::client::ApiClient::connect("127.0.0.1", port);
    if (!d || !f) return error("pollers: cannot connect");
    vog::api::MapMirror deltas;
    auto next = Clock::now();
    while (!stop) {
      next += std::chrono::duration_cast<Clock::duration>(poll_period);
      std::this_thread::sleep_until(next);
      vog::api::MapMirror whole;
      // Before the first closed submap there is no map (UNAVAILABLE): nothing to fetch yet.
      const auto fetch = [](vog::client::ApiClient& c, vog::api::MapMirror& m) -> vog::Status {
        vog::Status st = c.fetchMap(m);
        if (!st && c.lastServerError().code == vog::v1::ERROR_CODE_UNAVAILABLE && !c.broken()) return {};
        return st;
      };
      if (auto st = fetch(**d, deltas); !st) return error("deltas: " + st.error().message);
      if (auto st = fetch(**f, whole); !st) return error("full maps: " + st.error().message);
      const std::lock_guard lock(mutex);
      delta_bytes = (*d)->bytesReceived();
      full_bytes = (*f)->bytesReceived();
      ++polls;
    }
  });

  auto status = vog::client::ApiClient::connect("127.0.0.1", port);
  if (!status) return fail("status client: " + status.error().message);
  std::vector<vog::bench::ProcSample> samples;
  std::string final_state;
  vog::api::StatusReport last;
  const auto t0 = Clock::now();
  while (std::chrono::duration<double>(Clock::now() - t0).count() < max_s) {
    std::this_thread::sleep_for(std::chrono::seconds(1));
    if (auto s = vog::bench::sampleProc(viewer.pid())) samples.push_back(*s);
    auto st = (*status)->status();
    if (!st) return fail("status: " + st.error().message);
    last = *st;
    final_state = vog::api::toString(st->mission_state);
    const bool ended = st->mission_state == vog::api::MissionState::kComplete ||
                       st->mission_state == vog::api::MissionState::kAborted ||
                       st->mission_state == vog::api::MissionState::kNearHome;
    if (ended) break;
    {
      const std::lock_guard lock(mutex);
      if (!errors.empty()) break;
    }
  }
  const double wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  // The last submap closes just after the end: wait until the mirror holds vogd's final graph.
  for (int i = 0; i < 100; ++i) {
    auto st = (*status)->status();
    if (!st) break;
    last = *st;
    const std::lock_guard lock(mutex);
    if (mirror_graph_version == st->graph_version && mirror_submaps == st->n_submaps) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  stop = true;
  mirror_thread.join();
  poll_thread.join();
  if (page) page->signal(SIGTERM);
  const int page_status = page ? page->wait(20.0) : 0;
  if (auto s = vog::bench::sampleProc(viewer.pid())) samples.push_back(*s);
  viewer.signal(SIGTERM);
  const int viewer_status = viewer.wait(5.0);
  daemon.signal(SIGTERM);
  const int daemon_status = daemon.wait(10.0);
  if (!errors.empty()) return fail(errors.front());
  if (samples.size() < 2) return fail("no /proc samples of vog-console");

  vog::bench::JsonObject out;
  out.add("mission_state", final_state);
  out.add("wall_s", wall_s);
  out.add("speedup", speedup);
  out.add("submaps", static_cast<std::int64_t>(last.n_submaps));
  out.add("closures", static_cast<std::int64_t>(last.n_closures));
  out.add("graph_updates", static_cast<std::int64_t>(graph_updates));
  out.add("mirror_complete",
          static_cast<std::int64_t>(mirror_graph_version == last.graph_version && mirror_submaps == last.n_submaps));
  out.add("bytes_mirror", static_cast<std::int64_t>(mirror_bytes));
  out.add("bytes_mirror_submaps", static_cast<std::int64_t>(submap_bytes));
  out.add("bytes_mirror_graph", static_cast<std::int64_t>(graph_bytes));
  out.add("polls", static_cast<std::int64_t>(polls));
  out.add("poll_s_simulated", poll_s);
  out.add("bytes_deltas", static_cast<std::int64_t>(delta_bytes));
  out.add("bytes_full", static_cast<std::int64_t>(full_bytes));
  out.add("deltas_over_mirror",
          static_cast<double>(delta_bytes) / std::max<double>(1.0, static_cast<double>(mirror_bytes)));
  out.add("full_over_mirror",
          static_cast<double>(full_bytes) / std::max<double>(1.0, static_cast<double>(mirror_bytes)));
  out.add("moved_submaps", static_cast<std::int64_t>(moved_submaps));
  out.add("bytes_per_moved_submap_median", bytes_per_moved.empty() ? 0.0 : vog::bench::median(bytes_per_moved));
  out.add("bytes_per_moved_submap_max", bytes_per_moved.empty() ? 0.0 : vog::bench::percentile(bytes_per_moved, 1.0));
  out.add("console_cpu_pct_mean", 100.0 * (samples.back().cpu_s - samples.front().cpu_s) /
                                      std::max(1e-3, samples.back().t_s - samples.front().t_s));
  out.add("console_rss_mb_peak", samples.back().hwm_mb);
  out.add("console_rss_mb_end", samples.back().rss_mb);
  out.add("console_exit_status", static_cast<std::int64_t>(viewer_status));
  out.add("vogd_exit_status", static_cast<std::int64_t>(daemon_status));
  if (page) {
    out.add("page_exit_status", static_cast<std::int64_t>(page_status));
    // The page's figures (numbers only), prefixed.
    const nlohmann::json figures = nlohmann::json::parse(vog::test::readTextFile(dir / "page.json"), nullptr, false);
    if (!figures.is_object())
      return fail("the page measurement wrote no JSON: " + vog::test::readTextFile(dir / "page.log"));
    for (const auto& [key, value] : figures.items()) {
      if (value.is_number()) out.add("page_" + key, value.get<double>());
    }
  }
  std::cout << out.str();
  std::error_code ec;
  fs::remove_all(dir, ec);
  return viewer_status == 0 && daemon_status == 0 && page_status == 0 ? 0 : 1;
}
