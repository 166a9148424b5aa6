// API frames and request dispatch: arbitrary bytes from a client go through the FrameDecoder (whole
// and split at an input-chosen point, which must agree), and every decoded Envelope through the
// Dispatcher as an observer and as an operator, on a backend with a real (small) merged map. Every
// reply, chunked transfers included, must encode within the maximum frame size.
#include "fuzz_check.hpp"

#include "vog/api/dispatcher.hpp"
#include "vog/api/framing.hpp"
#include "vog/api/graph.hpp"
#include "vog/map/local_grid.hpp"

#include <memory>
#include <vector>

namespace {

using namespace vog;

constexpr std::uint32_t kMaxFrame = 64 * 1024;

class FuzzBackend final : public api::ApiBackend {
 public:
  FuzzBackend() {
    const map::GridConfig config;
    auto grid = map::LocalGrid::create(config).value();
    std::vector<map::BeamEnd> beams;
    for (int i = 0; i < 40; ++i) beams.push_back({Eigen::Vector3d(3.0, -1.0 + 0.05 * i, 0.3 * (i % 5)), i % 3 != 0});
    (void)grid->insertRays(Eigen::Vector3d::Zero(), beams);
    grid->finalize();
    merged_ = map::MergedMap::create(config).value();
    grid_ = std::move(grid);
    map::SubmapEntry entry;
    entry.grid = grid_;
    (void)merged_->add(entry);
    auto graph = std::make_shared<api::GraphState>();
    graph->version = 1;
    graph->submaps.push_back({0, entry.T_world_submap});
    graph_ = graph;
    snapshot_ = merged_->snapshot();
    auto cloud = std::make_shared<api::ServedCloud>();
    for (int i = 0; i < 100; ++i) cloud->points.push_back({Eigen::Vector3f(0.1f * static_cast<float>(i), 0, 0), {}});
    cloud_ = cloud;
  }
  api::StatusReport status() const override {
    api::StatusReport s;
    s.devices = {{"dvl", api::DeviceState::kOk, "", 0, 1, 0}};
    return s;
  }
  std::shared_ptr<const map::MergedMap> mapSnapshot() const override { return snapshot_; }
  std::vector<api::SubmapInfo> submaps() const override { return {api::SubmapInfo{}}; }
  std::shared_ptr<const api::GraphState> graph() const override { return graph_; }
  std::shared_ptr<const map::LocalGrid> submapGrid(std::uint32_t id) const override {
    return id == 0 ? grid_ : nullptr;
  }
  std::shared_ptr<const api::ServedCloud> cloud() const override { return cloud_; }
  Result<api::MissionState> command(const api::MissionCommand& c) override {
    if (c.kind == api::MissionCommand::Kind::kSetBox) VOG_FUZZ_CHECK(c.box.validate().ok());
    if (c.kind == api::MissionCommand::Kind::kResume) return Error{"resume while idle"};
    return api::MissionState::kIdle;
  }
  std::string configText() const override { return "api: {}\n"; }

 private:
  std::shared_ptr<const map::LocalGrid> grid_;
  std::shared_ptr<const api::GraphState> graph_;
  std::unique_ptr<map::MergedMap> merged_;
  std::shared_ptr<const map::MergedMap> snapshot_;
  std::shared_ptr<const api::ServedCloud> cloud_;
};

std::vector<std::string> decodeAll(api::FrameDecoder& decoder, bool& failed) {
  std::vector<std::string> out;
  for (;;) {
    api::FrameResult r = decoder.next();
    if (std::holds_alternative<api::FrameNeedMore>(r)) return out;
    if (std::holds_alternative<api::FrameError>(r)) {
      failed = true;
      return out;
    }
    out.push_back(std::get<v1::Envelope>(r).SerializeAsString());
  }
}

void checkReply(api::Reply reply) {
  for (const auto& e : reply.frames) VOG_FUZZ_CHECK(api::encodeFrame(e, kMaxFrame).ok());
  int n = 0;
  while (reply.chunks && !reply.chunks->done()) {
    VOG_FUZZ_CHECK(api::encodeFrame(reply.chunks->next(), kMaxFrame).ok());
    VOG_FUZZ_CHECK(++n < 100000);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static FuzzBackend backend;
  static api::SeededNonceSource nonces(1);
  api::DispatchConfig config;
  config.operator_secret = "fuzz-operator-secret";
  config.max_frame_bytes = kMaxFrame;
  config.map_blocks_per_chunk = 4;
  config.cloud_points_per_chunk = 16;
  static api::Dispatcher dispatcher(backend, nonces, nullptr, config);

  // The first byte picks where the stream is split in two feeds.
  const std::size_t split = size == 0 ? 0 : (data[0] * size) / 256;
  api::FrameDecoder whole(kMaxFrame);
  whole.feed(std::span<const std::uint8_t>(data, size));
  bool whole_failed = false;
  const auto frames = decodeAll(whole, whole_failed);

  api::FrameDecoder parts(kMaxFrame);
  bool parts_failed = false;
  parts.feed(std::span<const std::uint8_t>(data, split));
  auto split_frames = decodeAll(parts, parts_failed);
  parts.feed(std::span<const std::uint8_t>(data + split, size - split));
  for (auto& f : decodeAll(parts, parts_failed)) split_frames.push_back(std::move(f));
  VOG_FUZZ_CHECK(frames == split_frames);
  VOG_FUZZ_CHECK(whole_failed == parts_failed);

  api::SessionState observer;
  api::SessionState op;
  op.role = api::Role::kOperator;
  for (const std::string& bytes : frames) {
    v1::Envelope e;
    VOG_FUZZ_CHECK(e.ParseFromString(bytes));
    checkReply(dispatcher.handle(e, observer));
    VOG_FUZZ_CHECK(observer.role == api::Role::kObserver);  // no way to become operator without the MAC
    checkReply(dispatcher.handle(e, op));
    // What a client does with a graph update from the server: decoded (or refused with a reason), then
    // applied to the graph it holds (or refused, leaving that graph as it was).
    if (e.has_graph_update()) {
      auto update = api::fromProto(e.graph_update());
      if (!update) {
        VOG_FUZZ_CHECK(!update.error().message.empty());
        continue;
      }
      api::GraphState held = *backend.graph();
      const api::GraphState before = held;
      auto set = api::applyGraphUpdate(held, *update);
      if (!set) {
        VOG_FUZZ_CHECK(held.version == before.version && held.submaps.size() == before.submaps.size());
      } else {
        VOG_FUZZ_CHECK(held.version == update->version);
        for (const api::SubmapPose& p : held.submaps) VOG_FUZZ_CHECK(p.T_world_submap.matrix().allFinite());
      }
    }
  }
  return 0;
}
