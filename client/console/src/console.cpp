#include "vog/console/console.hpp"

#include <algorithm>
#include <chrono>

namespace vog::console {

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

std::int64_t unixMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

const BlockVoxels kNoVoxels;

}  // namespace

Result<std::unique_ptr<Console>> Console::start(ConsoleConfig config) {
  if (auto st = config.client.validate(); !st) return st.error();
  if (config.reconnect_min.count() <= 0 || config.reconnect_max < config.reconnect_min) {
    return Error{"reconnect delays: need 0 < min <= max"};
  }
  if (config.max_voxels_per_message < 512) return Error{"max_voxels_per_message must be at least one block (512)"};
  std::unique_ptr<Console> console(new Console(std::move(config)));
  Console* self = console.get();
  WebServerCallbacks callbacks;
  callbacks.opened = [self](ClientId page) {
    const std::lock_guard lock(self->mutex_);
    self->pages_[page] = false;
    self->sendSnapshotLocked(page);
  };
  callbacks.text = [self](ClientId page, std::string text) { self->onPageText(page, text); };
  callbacks.closed = [self](ClientId page) {
    const std::lock_guard lock(self->mutex_);
    self->pages_.erase(page);
  };
  callbacks.state_json = [self] { return self->stateJson(); };
  auto web = WebServer::start(self->config_.web, std::move(callbacks));
  if (!web) return Error{"web server: " + web.error().message};
  console->web_ = std::move(web).value();
  console->link_thread_ = std::thread([self] { self->runLink(); });
  return console;
}

Console::Console(ConsoleConfig config) : config_(std::move(config)) {
  controls_why_ = config_.secret.empty() ? config_.no_secret_why : "not connected to vogd yet";
  status_ = {{"type", "status"}};
}

Console::~Console() { stop(); }

void Console::stop() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (link_thread_.joinable()) link_thread_.join();
  if (web_) web_->stop();
}

void Console::dropLink() {
  {
    const std::lock_guard lock(mutex_);
    drop_requested_ = true;
  }
  wake_.notify_all();
}

MirrorView Console::view() const {
  const std::lock_guard lock(mutex_);
  return view_;
}

// ------------------------------------------------------------------------------------------ the link

void Console::runLink() {
  auto backoff = config_.reconnect_min;
  std::uint64_t bytes_before = 0;
  for (;;) {
    {
      const std::lock_guard lock(mutex_);
      if (stopping_) return;
      drop_requested_ = false;
    }
    setLink("connecting", config_.host + ":" + std::to_string(config_.port));
    auto c = client::ApiClient::connect(config_.host, config_.port, config_.client);
    Status ended = c ? Status{} : Status{c.error()};
    const Clock::time_point connected_at = Clock::now();
    if (c) {
      {
        const std::lock_guard lock(mutex_);
        live_ = c->get();
      }
      ended = session(**c);
      const std::lock_guard lock(mutex_);
      live_ = nullptr;
      bytes_before += (*c)->bytesReceived();
      view_.bytes_received = bytes_before;
      view_.connected = false;
    }
    {
      const std::lock_guard lock(mutex_);
      if (stopping_) return;
      ++view_.reconnects;
      controls_ = false;
      controls_why_ = config_.secret.empty() ? config_.no_secret_why : "not connected to vogd";
    }
    setLink("disconnected", ended ? std::string("the connection closed") : ended.error().message);
    if (Clock::now() - connected_at > config_.reconnect_max) backoff = config_.reconnect_min;
    std::unique_lock lock(mutex_);
    wake_.wait_for(lock, backoff, [this] { return stopping_; });
    backoff = std::min(config_.reconnect_max, backoff * 2);
  }
}

Status Console::session(client::ApiClient& c) {
  auto hello = c.hello();
  if (!hello) return hello.error();
  bool controls = false;
  std::string why = config_.no_secret_why;
  if (!config_.secret.empty()) {
    if (!hello->operator_enabled) {
      why = "vogd has no operator secret (api.secret_file)";
    } else if (auto role = c.authenticate(config_.secret); !role) {
      if (c.broken()) return role.error();
      why = "authentication failed: " + role.error().message;
    } else {
      controls = *role == api::Role::kOperator;
      why = controls ? "" : "vogd did not grant the operator role";
    }
  }
  {
    const std::lock_guard lock(mutex_);
    controls_ = controls;
    controls_why_ = why;
    if (!controls && !config_.secret.empty()) eventLocked("warning", "controls off: " + why);
    const Json hello_msg = {{"type", "hello"},
                            {"protocol", 1},
                            {"controls", controls_},
                            {"controls_reason", controls_why_},
                            {"server", "vog-console"}};
    web_->broadcastText(hello_msg.dump());
  }
  if (auto s = c.subscribe({true, true, true, true}); !s) return s.error();
  if (auto s = c.status(); s) {
    last_status_ = *s;
    have_status_ = true;
    const std::lock_guard lock(mutex_);
    status_ = statusJson(*s);
    web_->broadcastText(statusLocked().dump());
  } else {
    return s.error();
  }
  setLink("connected", config_.host + ":" + std::to_string(config_.port));
  {
    const std::lock_guard lock(mutex_);
    view_.connected = true;
  }
  const std::uint64_t bytes_before = [&] {
    const std::lock_guard lock(mutex_);
    return view_.bytes_received;
  }();
  for (;;) {
    {
      const std::lock_guard lock(mutex_);
      if (stopping_) return {};
      if (drop_requested_) return Error{"the link was dropped"};
      view_.bytes_received = bytes_before + c.bytesReceived();
    }
    runCommands(c);
    auto m = c.nextStream(100ms);
    if (!m) {
      if (c.broken()) return m.error();
      if (!c.timedOut()) {  // a message that did not decode, or an error frame the server did not close on
        const std::lock_guard lock(mutex_);
        eventLocked("warning", "from vogd: " + m.error().message);
      }
      continue;
    }
    if (auto* g = std::get_if<api::GraphUpdate>(&*m)) {
      if (Status st = onGraph(c, *g); !st) return st;
    } else if (auto* p = std::get_if<api::PoseUpdate>(&*m)) {
      Json j = poseJson(p->T_world_vehicle);
      j["type"] = "pose";
      j["seq"] = p->seq;
      j["stamp_ns"] = p->stamp_ns;
      j["published_unix_ms"] = static_cast<double>(p->published_unix_ns) / 1e6;
      const std::lock_guard lock(mutex_);
      const Eigen::Vector3d t = p->T_world_vehicle.translation();
      if (path_.empty() || (Eigen::Vector3d(path_.back()[0], path_.back()[1], path_.back()[2]) - t).norm() > 0.05) {
        path_.push_back({t.x(), t.y(), t.z()});
        if (path_.size() > config_.max_path_points) {
          std::vector<std::array<double, 3>> thinned;
          for (std::size_t i = 0; i < path_.size(); i += 2) thinned.push_back(path_[i]);
          thinned.push_back(path_.back());
          path_ = std::move(thinned);
        }
      }
      web_->broadcastText(j.dump());
    } else if (auto* w = std::get_if<api::Waypoint>(&*m)) {
      const Json j = waypointJson(*w);
      const std::lock_guard lock(mutex_);
      waypoints_.push_back(j);
      while (waypoints_.size() > 500) waypoints_.pop_front();
      web_->broadcastText(j.dump());
    } else if (auto* s = std::get_if<api::StatusUpdate>(&*m)) {
      const api::StatusReport& now = s->status;
      const std::lock_guard lock(mutex_);
      if (have_status_) {
        if (now.mission_state != last_status_.mission_state) {
          eventLocked("info", std::string("mission: ") + api::toString(now.mission_state));
        }
        if (now.n_closures > last_status_.n_closures) {
          eventLocked("info", "loop closures: " + std::to_string(now.n_closures));
        }
        for (const api::DeviceHealth& d : now.devices) {
          const auto before = std::find_if(last_status_.devices.begin(), last_status_.devices.end(),
                                           [&](const api::DeviceHealth& o) { return o.name == d.name; });
          if (before == last_status_.devices.end() || before->state != d.state) {
            eventLocked(d.state == api::DeviceState::kOk ? "info" : "warning",
                        d.name + ": " + api::toString(d.state) + (d.detail.empty() ? "" : " (" + d.detail + ")"));
          }
        }
      }
      last_status_ = now;
      have_status_ = true;
      status_ = statusJson(now);
      web_->broadcastText(statusLocked().dump());
    }
  }
}

Status Console::onGraph(client::ApiClient& c, const api::GraphUpdate& update) {
  // What the pages are told: the update with the poses it set (moved ones resolved against the held).
  api::GraphUpdate applied = update;
  auto set = mirror_.applyGraph(update);
  if (!set) {
    auto full = c.graph();
    if (!full) return full.error();
    set = mirror_.applyGraph(*full);
    if (!set) return set.error();
    applied = std::move(full).value();
  }
  applied.submaps = std::move(set).value();
  applied.moved.clear();
  for (const std::uint32_t id : mirror_.missingGrids()) {
    auto grid = c.fetchSubmap(id);
    if (!grid) {
      if (c.broken()) return grid.error();
      const std::lock_guard lock(mutex_);
      eventLocked("warning", "submap " + std::to_string(id) + " not fetched: " + grid.error().message);
      continue;
    }
    if (Status st = mirror_.addGrid(id, std::move(grid).value()); !st) return st;
    const std::lock_guard lock(mutex_);
    ++view_.submaps_fetched;
  }
  auto synced = mirror_.sync();
  if (!synced) return Error{"merging the mirror: " + synced.error().message};
  {
    const std::lock_guard lock(mutex_);
    graph_full_ = graphJson(api::graphUpdate(nullptr, mirror_.graph()));
    web_->broadcastText(graphJson(applied).dump());
  }
  publishVoxels();
  return {};
}

void Console::publishVoxels() {
  const map::MergedMap* merged = mirror_.merged();
  if (merged == nullptr) return;
  const auto changed = merged->blocksChangedSince(sent_map_version_);
  const auto removed = merged->blocksRemovedSince(sent_map_version_);
  const map::LogOddsBounds bounds = merged->config().bounds();
  std::vector<std::pair<BlockKey, BlockVoxels>> classified;
  classified.reserve(changed.size());
  for (const auto& [origin, block] : changed) {
    classified.emplace_back(BlockKey(origin.x() >> 3, origin.y() >> 3, origin.z() >> 3), classifyBlock(*block, bounds));
  }
  std::shared_ptr<const map::MergedMap> snapshot = mirror_.snapshot();
  const std::lock_guard lock(mutex_);
  std::vector<std::pair<BlockKey, const BlockVoxels*>> delta;
  delta.reserve(classified.size() + removed.size());
  const auto drop = [&](const BlockKey& key) {
    const auto it = blocks_.find(key);
    if (it == blocks_.end()) return;
    view_.occupied -= it->second.occupied.size();
    view_.free -= it->second.free.size();
    blocks_.erase(it);
  };
  for (const map::VoxelKey& origin : removed) {
    const BlockKey key(origin.x() >> 3, origin.y() >> 3, origin.z() >> 3);
    drop(key);
    delta.emplace_back(key, &kNoVoxels);
  }
  for (auto& [key, voxels] : classified) {
    drop(key);
    view_.occupied += voxels.occupied.size();
    view_.free += voxels.free.size();
    if (voxels.empty()) {
      delta.emplace_back(key, &kNoVoxels);
      continue;
    }
    const auto it = blocks_.emplace(key, std::move(voxels)).first;
    delta.emplace_back(key, &it->second);
  }
  sent_map_version_ = merged->version();
  view_.map_version = merged->version();
  view_.graph_version = mirror_.syncedVersion();
  view_.complete = mirror_.syncedComplete();
  view_.submaps = mirror_.gridCount();
  view_.merged = std::move(snapshot);
  if (delta.empty()) return;
  for (const auto& [page, free] : pages_) {
    (void)free;
    sendVoxelsLocked(page, delta, false);
  }
}

void Console::runCommands(client::ApiClient& c) {
  for (;;) {
    std::pair<ClientId, PageCommand> next;
    {
      const std::lock_guard lock(mutex_);
      if (commands_.empty()) return;
      next = std::move(commands_.front());
      commands_.pop_front();
    }
    bool ok = true;
    std::string text;
    for (const api::MissionCommand& command : next.second.commands) {
      auto r = c.command(command);
      if (!r) {
        ok = false;
        text = r.error().message;
        break;
      }
      text = std::string("mission ") + api::toString(*r);
    }
    const std::lock_guard lock(mutex_);
    eventLocked(ok ? "info" : "warning",
                std::string(api::toString(next.second.commands.back().kind)) + (ok ? ": " : " refused: ") + text);
    replyLocked(next.first, next.second.id, ok, text);
  }
}

// ------------------------------------------------------------------------------------------ the pages

void Console::onPageText(ClientId page, const std::string& text) {
  auto parsed = parsePageMessage(text);
  const std::lock_guard lock(mutex_);
  if (const auto* e = std::get_if<PageError>(&parsed)) {
    if (e->id) {
      replyLocked(page, *e->id, false, e->text);
    } else {
      web_->sendText(page, Json({{"type", "error"}, {"text", e->text}}).dump());
    }
    return;
  }
  PageMessage& m = std::get<PageMessage>(parsed);
  if (m.view) {
    const auto it = pages_.find(page);
    if (it == pages_.end() || it->second == m.view->free) return;
    it->second = m.view->free;
    std::vector<std::pair<BlockKey, const BlockVoxels*>> all;
    all.reserve(blocks_.size());
    for (const auto& [key, voxels] : blocks_) all.emplace_back(key, &voxels);
    sendVoxelsLocked(page, all, true);
    return;
  }
  if (!controls_) {
    replyLocked(page, m.command->id, false, "the controls are off: " + controls_why_);
    return;
  }
  commands_.emplace_back(page, std::move(*m.command));
}

void Console::replyLocked(ClientId page, std::int64_t id, bool ok, const std::string& text) {
  web_->sendText(page, Json({{"type", "reply"}, {"id", id}, {"ok", ok}, {"text", text}}).dump());
}

void Console::sendSnapshotLocked(ClientId page) {
  web_->sendText(page, Json({{"type", "hello"},
                             {"protocol", 1},
                             {"controls", controls_},
                             {"controls_reason", controls_why_},
                             {"server", "vog-console"}})
                           .dump());
  web_->sendText(page, Json({{"type", "link"},
                             {"state", link_state_},
                             {"detail", link_detail_},
                             {"host", config_.host + ":" + std::to_string(config_.port)}})
                           .dump());
  web_->sendText(page, statusLocked().dump());
  Json points = Json::array();
  for (const auto& p : path_) points.push_back(Json::array({p[0], p[1], p[2]}));
  web_->sendText(page, Json({{"type", "path"}, {"points", std::move(points)}}).dump());
  web_->sendText(page, Json({{"type", "waypoints"}, {"items", Json(waypoints_)}}).dump());
  web_->sendText(page, graph_full_.dump());
  web_->sendText(page, Json({{"type", "events"}, {"items", Json(events_)}}).dump());
  std::vector<std::pair<BlockKey, const BlockVoxels*>> all;
  all.reserve(blocks_.size());
  for (const auto& [key, voxels] : blocks_) all.emplace_back(key, &voxels);
  sendVoxelsLocked(page, all, true);
}

void Console::sendVoxelsLocked(ClientId page, const std::vector<std::pair<BlockKey, const BlockVoxels*>>& blocks,
                               bool reset) {
  const auto it = pages_.find(page);
  const bool free = it != pages_.end() && it->second;
  const double resolution = view_.merged ? view_.merged->resolution() : 0.0;
  for (std::string& m : encodeVoxelMessages(blocks, resolution, view_.map_version, reset, free, view_.occupied,
                                            config_.max_voxels_per_message)) {
    web_->sendBinary(page, std::move(m));
  }
}

Json Console::statusLocked() const {
  Json s = status_;
  s["mirror"] = {{"submaps", view_.submaps},
                 {"occupied", view_.occupied},
                 {"free", view_.free},
                 {"map_version", view_.map_version},
                 {"graph_version", view_.graph_version},
                 {"complete", view_.complete},
                 {"bytes_received", view_.bytes_received}};
  s["link"] = link_state_;
  s["controls"] = controls_;
  return s;
}

std::string Console::stateJson() const {
  const std::lock_guard lock(mutex_);
  return statusLocked().dump();
}

void Console::eventLocked(const std::string& level, const std::string& text) {
  Json e = {{"type", "event"}, {"unix_ms", unixMs()}, {"level", level}, {"text", text}};
  events_.push_back(e);
  while (events_.size() > config_.max_events) events_.pop_front();
  if (web_) web_->broadcastText(e.dump());
}

void Console::setLink(const std::string& state, const std::string& detail) {
  const std::lock_guard lock(mutex_);
  if (state != link_state_) eventLocked(state == "connected" ? "info" : "warning", "link " + state + ": " + detail);
  link_state_ = state;
  link_detail_ = detail;
  web_->broadcastText(Json({{"type", "link"},
                            {"state", state},
                            {"detail", detail},
                            {"host", config_.host + ":" + std::to_string(config_.port)}})
                          .dump());
}

}  // namespace vog::console
