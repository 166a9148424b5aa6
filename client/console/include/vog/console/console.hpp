#pragma once
// vog-console: the link to vogd and the pages it serves (client/console/README.md).
//
// Threads and ownership:
//  - the link thread owns the ApiClient and the SubmapMirror: it connects (reconnecting 1 s, doubling to
//    10 s), authenticates when it has the operator secret, subscribes to every stream, fetches each
//    closed submap once, merges, and runs the pages' commands between stream messages;
//  - the web server's thread runs the HTTP and WebSocket sessions and calls back on page events;
//  - everything both read (the pages' view of the mission: status, path, waypoints, events, the voxel
//    blocks, the connected pages) is under `mutex_`. Messages to the pages are sent while holding it, so
//    a page that opens gets a snapshot and then exactly the changes after it, in order.

#include "vog/client/api_client.hpp"
#include "vog/console/page_messages.hpp"
#include "vog/console/submap_mirror.hpp"
#include "vog/console/web_server.hpp"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

namespace vog::console {

struct ConsoleConfig {
  std::string host = "127.0.0.1";
  std::uint16_t port = 29600;
  client::ClientConfig client;
  std::string secret;         // the operator secret; empty: observer (the controls are off)
  std::string no_secret_why;  // shown on the page when `secret` is empty
  WebServerConfig web;
  std::chrono::milliseconds reconnect_min{1000};
  std::chrono::milliseconds reconnect_max{10000};
  std::size_t max_voxels_per_message = 40000;  // a page applies one message per slice of frames
  std::size_t max_events = 200;
  std::size_t max_path_points = 20000;  // older points are thinned, every second one dropped
};

// What the mirror holds now (tests, the benchmark, /api/state).
struct MirrorView {
  bool connected = false;
  std::uint64_t graph_version = 0;  // the graph the merged map was synced at
  bool complete = false;            // every submap of that graph was in the merge
  std::size_t submaps = 0;
  std::uint64_t occupied = 0;
  std::uint64_t free = 0;
  std::uint64_t map_version = 0;      // the mirror's own merged-map version
  std::uint64_t bytes_received = 0;   // over the link, every connection
  std::uint64_t submaps_fetched = 0;  // GetSubmap calls that succeeded
  std::uint64_t reconnects = 0;
  std::shared_ptr<const map::MergedMap> merged;  // snapshot; null before the first submap
};

class Console {
 public:
  static Result<std::unique_ptr<Console>> start(ConsoleConfig config);
  ~Console();
  Console(const Console&) = delete;
  Console& operator=(const Console&) = delete;

  void stop();
  std::uint16_t webPort() const { return web_->port(); }
  MirrorView view() const;
  std::string stateJson() const;
  // Closes the link's connection (as a dropped tether would); the link reconnects and catches up.
  void dropLink();

 private:
  explicit Console(ConsoleConfig config);
  void runLink();
  // One connection, until it breaks or the console stops.
  Status session(client::ApiClient& c);
  Status onGraph(client::ApiClient& c, const api::GraphUpdate& update);
  void runCommands(client::ApiClient& c);
  void publishVoxels();  // link thread, after a sync
  Json statusLocked() const;
  void eventLocked(const std::string& level, const std::string& text);
  void setLink(const std::string& state, const std::string& detail);
  void sendSnapshotLocked(ClientId page);
  void sendVoxelsLocked(ClientId page, const std::vector<std::pair<BlockKey, const BlockVoxels*>>& blocks, bool reset);
  void onPageText(ClientId page, const std::string& text);
  void replyLocked(ClientId page, std::int64_t id, bool ok, const std::string& text);

  const ConsoleConfig config_;
  std::unique_ptr<WebServer> web_;
  std::thread link_thread_;

  // Link thread only.
  SubmapMirror mirror_;
  std::uint64_t sent_map_version_ = 0;  // the merged-map version the pages were sent up to
  api::StatusReport last_status_;
  bool have_status_ = false;

  mutable std::mutex mutex_;
  std::condition_variable wake_;                           // stop and reconnect waits
  bool stopping_ = false;                                  // guarded by mutex_
  client::ApiClient* live_ = nullptr;                      // guarded by mutex_ (dropLink)
  bool drop_requested_ = false;                            // guarded by mutex_
  std::map<ClientId, bool> pages_;                         // page -> wants free voxels; guarded by mutex_
  std::deque<std::pair<ClientId, PageCommand>> commands_;  // guarded by mutex_
  bool controls_ = false;                                  // guarded by mutex_
  std::string controls_why_;                               // guarded by mutex_
  std::string link_state_ = "connecting";                  // guarded by mutex_
  std::string link_detail_;                                // guarded by mutex_
  Json status_;                                            // the newest status message; guarded by mutex_
  std::vector<std::array<double, 3>> path_;                // guarded by mutex_
  std::deque<Json> waypoints_;                             // guarded by mutex_
  std::deque<Json> events_;                                // guarded by mutex_
  Json graph_full_ = {{"type", "graph"},
                      {"version", 0},
                      {"full", true},
                      {"submaps", Json::array()},
                      {"closures", Json::array()}};  // the mirror's whole graph; guarded by mutex_
  BlockMap blocks_;                                  // the merged map as the pages hold it; guarded by mutex_
  MirrorView view_;                                  // guarded by mutex_
};

}  // namespace vog::console
