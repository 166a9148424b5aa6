// ApiClient's chunked transfers (map and cloud share one sequence check) against a scripted server
// on a real loopback socket that answers with chunks out of order, with a changing count, or with
// another message: each is an error naming the transfer and the chunk, never a partial result.
#include "vog/api/framing.hpp"
#include "vog/api/map_delta.hpp"
#include "vog/client/api_client.hpp"

#include <asio.hpp>
#include <gtest/gtest.h>

#include <functional>
#include <thread>

namespace vog::client {
namespace {

using asio::ip::tcp;
using namespace std::chrono_literals;

// Accepts one client, reads its first request and answers with `reply(request_id)`'s envelopes.
class ScriptedServer {
 public:
  explicit ScriptedServer(std::function<std::vector<v1::Envelope>(std::uint64_t)> reply)
      : acceptor_(io_, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0)), reply_(std::move(reply)) {
    thread_ = std::thread([this] { serve(); });
  }
  ~ScriptedServer() { thread_.join(); }
  std::uint16_t port() const { return acceptor_.local_endpoint().port(); }

 private:
  void serve() {
    tcp::socket socket(io_);
    acceptor_.accept(socket);
    api::FrameDecoder decoder(1u << 20);
    std::array<char, 4096> buf{};
    for (;;) {
      asio::error_code ec;
      const std::size_t n = socket.read_some(asio::buffer(buf), ec);
      if (ec) return;
      decoder.feed(std::string_view(buf.data(), n));
      api::FrameResult r = decoder.next();
      if (const auto* e = std::get_if<v1::Envelope>(&r)) {
        for (const auto& out : reply_(e->request_id())) {
          const std::string frame = api::encodeFrame(out).value();
          asio::write(socket, asio::buffer(frame), ec);
        }
        socket.shutdown(tcp::socket::shutdown_send, ec);
        while (!ec) socket.read_some(asio::buffer(buf), ec);  // until the client closes
        return;
      }
    }
  }

  asio::io_context io_;
  tcp::acceptor acceptor_;
  std::function<std::vector<v1::Envelope>(std::uint64_t)> reply_;
  std::thread thread_;
};

v1::Envelope cloudChunk(std::uint64_t id, std::uint32_t index, std::uint32_t count, std::uint64_t total,
                        std::vector<float> xyz) {
  v1::Envelope e;
  e.set_request_id(id);
  auto* c = e.mutable_cloud_chunk();
  c->set_chunk_index(index);
  c->set_chunk_count(count);
  c->set_points_total(total);
  for (const float v : xyz) c->add_xyz_m(v);
  return e;
}

v1::Envelope mapChunk(std::uint64_t id, std::uint32_t index, std::uint32_t count) {
  v1::Envelope e;
  e.set_request_id(id);
  auto* c = e.mutable_map_chunk();
  c->set_chunk_index(index);
  c->set_chunk_count(count);
  c->mutable_delta()->set_version(5);
  return e;
}

std::unique_ptr<ApiClient> connectTo(const ScriptedServer& server) {
  ClientConfig config;
  config.timeout = 3s;
  return ApiClient::connect("127.0.0.1", server.port(), config).value();
}

std::string cloudError(std::function<std::vector<v1::Envelope>(std::uint64_t)> reply) {
  ScriptedServer server(std::move(reply));
  auto c = connectTo(server);
  auto r = c->cloud();
  return r.ok() ? "no error: " + std::to_string(r->size()) + " points" : r.error().message;
}

TEST(ChunkSequence, CloudChunksInOrderAssembleTheCloud) {
  ScriptedServer server([](std::uint64_t id) {
    return std::vector{cloudChunk(id, 0, 2, 3, {1, 2, 3, 4, 5, 6}), cloudChunk(id, 1, 2, 3, {7, 8, 9})};
  });
  auto c = connectTo(server);
  std::vector<std::uint64_t> progress;
  auto cloud = c->cloud([&](std::uint64_t n, std::uint64_t) { progress.push_back(n); });
  ASSERT_TRUE(cloud.ok()) << cloud.error().message;
  ASSERT_EQ(cloud->size(), 3u);
  EXPECT_EQ((*cloud)[2].p_world_m, Eigen::Vector3f(7, 8, 9));
  EXPECT_EQ(progress, (std::vector<std::uint64_t>{2, 3}));
}

TEST(ChunkSequence, OutOfOrderChangedCountOrForeignMessagesAreErrors) {
  EXPECT_EQ(cloudError([](std::uint64_t id) {
              return std::vector{cloudChunk(id, 1, 2, 3, {1, 2, 3})};
            }),
            "cloud: chunk 1 of 2 arrived, expected chunk 0");
  EXPECT_EQ(cloudError([](std::uint64_t id) {
              return std::vector{cloudChunk(id, 0, 2, 2, {1, 2, 3}), cloudChunk(id, 1, 3, 2, {4, 5, 6})};
            }),
            "cloud: chunk 1 of 3 arrived, expected chunk 1");
  EXPECT_EQ(cloudError([](std::uint64_t id) { return std::vector{cloudChunk(id, 0, 0, 0, {})}; }),
            "cloud: chunk 0 of 0 arrived, expected chunk 0");
  EXPECT_EQ(cloudError([](std::uint64_t id) { return std::vector{mapChunk(id, 0, 1)}; }),
            "cloud: the server answered with another message");
  // The per-transfer check still runs inside the shared loop.
  EXPECT_EQ(cloudError([](std::uint64_t id) {
              return std::vector{cloudChunk(id, 0, 1, 1, {1, 2})};
            }),
            "cloud: chunk 0 has 2 coordinates and 0 normal components");

  ScriptedServer server([](std::uint64_t id) { return std::vector{mapChunk(id, 0, 2), mapChunk(id, 0, 2)}; });
  auto c = connectTo(server);
  api::MapMirror mirror;
  const Status s = c->fetchMap(mirror);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().message, "map: chunk 0 of 2 arrived, expected chunk 1");
  EXPECT_EQ(mirror.version(), 0u);  // unchanged
}

}  // namespace
}  // namespace vog::client
