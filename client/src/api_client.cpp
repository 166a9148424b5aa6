#include "vog/client/api_client.hpp"

#include "vog/api/submap_transfer.hpp"

#include "vog/api/auth.hpp"
#include "vog/api/convert.hpp"
#include "vog/api/dispatcher.hpp"
#include "vog/api/framing.hpp"

#include <asio.hpp>
#include <asio/ssl.hpp>

#include <algorithm>
#include <array>
#include <optional>
#include <thread>

namespace vog::client {

namespace {

using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

std::string ms(std::chrono::milliseconds d) { return std::to_string(d.count()) + " ms"; }

bool isStream(v1::Envelope::BodyCase body) {
  return body == v1::Envelope::kWaypoint || body == v1::Envelope::kPoseUpdate || body == v1::Envelope::kStatusUpdate ||
         body == v1::Envelope::kGraphUpdate;
}

}  // namespace

struct ApiClient::Impl {
  explicit Impl(std::uint32_t max_frame_bytes) : decoder(max_frame_bytes) {}

  // Runs the io_context until `done` is set or the deadline passes; on timeout the socket's pending
  // operations are cancelled (their handlers run, setting `done`) and false is returned.
  bool runUntil(const bool& done, Clock::time_point deadline) {
    io.restart();
    while (!done) {
      if (io.run_one_until(deadline) == 0) break;
    }
    if (done) return true;
    asio::error_code ec;
    socket.cancel(ec);
    io.restart();
    while (!done && io.run_one() != 0) {
    }
    return false;
  }

  // The byte stream: the TLS stream over the socket, or the socket itself.
  template <class F>
  void withStream(F&& f) {
    if (tls) {
      f(*tls);
    } else {
      f(socket);
    }
  }

  asio::io_context io;
  tcp::socket socket{io};
  std::unique_ptr<asio::ssl::context> tls_context;     // outlives the stream
  std::optional<asio::ssl::stream<tcp::socket&>> tls;  // over `socket` when TLS is on
  api::FrameDecoder decoder;
  std::array<std::uint8_t, 64 * 1024> buf{};
};

Status ClientConfig::validate() const {
  if (max_frame_bytes < 1024 || max_frame_bytes > api::kFrameBytesLimit) {
    return Error{"client.max_frame_bytes: " + std::to_string(max_frame_bytes) + " is outside [1024, " +
                 std::to_string(api::kFrameBytesLimit) + "]"};
  }
  if (timeout.count() < 1) return Error{"client.timeout: " + ms(timeout) + " must be positive"};
  if (max_buffered_streams < 1) return Error{"client.max_buffered_streams: must be at least 1"};
  if (socket_receive_buffer_bytes < 0) {
    return Error{"client.socket_receive_buffer_bytes: " + std::to_string(socket_receive_buffer_bytes) + " is negative"};
  }
  return {};
}

Error toError(const v1::Error& error) { return Error{v1::ErrorCode_Name(error.code()) + ": " + error.message()}; }

namespace {

// The client side of the TLS handshake: TLS 1.2 or newer, the server's certificate verified
// against the CA file (or the system's CAs) and checked to name `host`.
Status startTls(ApiClient::Impl& impl, const std::string& host, std::uint16_t port, const ClientConfig& config,
                Clock::time_point deadline) {
  const std::string where = host + ":" + std::to_string(port);
  impl.tls_context = std::make_unique<asio::ssl::context>(asio::ssl::context::tls_client);
  asio::ssl::context& context = *impl.tls_context;
  asio::error_code ec;
  context.set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                          asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 | asio::ssl::context::no_tlsv1_1,
                      ec);
  if (config.tls.ca_file.empty()) {
    context.set_default_verify_paths(ec);
  } else {
    context.load_verify_file(config.tls.ca_file.string(), ec);
    if (ec) return Error{"TLS: cannot read the CA file " + config.tls.ca_file.string() + ": " + ec.message()};
  }
  context.set_verify_mode(asio::ssl::verify_peer);
  impl.tls.emplace(impl.socket, context);
  impl.tls->set_verify_callback(asio::ssl::host_name_verification(host));
  asio::error_code not_ip;
  (void)asio::ip::make_address(host, not_ip);
  if (not_ip) {
    // SNI, for names only (RFC 6066); SSL_set_tlsext_host_name without its C cast.
    ::SSL_ctrl(impl.tls->native_handle(), SSL_CTRL_SET_TLSEXT_HOSTNAME, TLSEXT_NAMETYPE_host_name,
               const_cast<char*>(host.c_str()));
  }
  bool done = false;
  impl.tls->async_handshake(asio::ssl::stream_base::client, [&](const asio::error_code& e) {
    ec = e;
    done = true;
  });
  if (!impl.runUntil(done, deadline)) return Error{"TLS handshake with " + where + " timed out"};
  if (ec) return Error{"TLS handshake with " + where + " failed: " + ec.message()};
  return {};
}

}  // namespace

Result<std::unique_ptr<ApiClient>> ApiClient::connect(const std::string& host, std::uint16_t port,
                                                      ClientConfig config) {
  if (Status s = config.validate(); !s.ok()) return s.error();
  auto impl = std::make_unique<Impl>(config.max_frame_bytes);
  asio::error_code ec;
  tcp::resolver resolver(impl->io);
  const auto endpoints = resolver.resolve(host, std::to_string(port), ec);
  if (ec) return Error{"cannot resolve '" + host + "': " + ec.message()};
  const Clock::time_point deadline = Clock::now() + config.timeout;
  ec = asio::error::host_not_found;
  for (const auto& entry : endpoints) {
    // Options set before connect: the receive buffer decides the TCP window announced in the handshake.
    asio::error_code open_ec;
    impl->socket.close(open_ec);
    impl->socket.open(entry.endpoint().protocol(), open_ec);
    if (open_ec) {
      ec = open_ec;
      continue;
    }
    if (config.socket_receive_buffer_bytes > 0) {
      impl->socket.set_option(asio::socket_base::receive_buffer_size(config.socket_receive_buffer_bytes), open_ec);
    }
    bool done = false;
    impl->socket.async_connect(entry.endpoint(), [&](const asio::error_code& e) {
      ec = e;
      done = true;
    });
    if (!impl->runUntil(done, deadline)) {
      return Error{"connecting to " + host + ":" + std::to_string(port) + " timed out after " + ms(config.timeout)};
    }
    if (!ec) break;
  }
  if (ec) return Error{"cannot connect to " + host + ":" + std::to_string(port) + ": " + ec.message()};
  impl->socket.set_option(tcp::no_delay(true), ec);
  if (config.tls.enabled) {
    if (Status s = startTls(*impl, host, port, config, deadline); !s.ok()) return s.error();
  }
  return std::unique_ptr<ApiClient>(new ApiClient(std::move(impl), std::move(config)));
}

ApiClient::ApiClient(std::unique_ptr<Impl> impl, ClientConfig config)
    : impl_(std::move(impl)), config_(std::move(config)) {}

ApiClient::~ApiClient() {
  asio::error_code ec;
  impl_->socket.close(ec);
}

Error ApiClient::fail(std::string message) {
  broken_ = true;
  asio::error_code ec;
  impl_->socket.close(ec);
  return Error{std::move(message)};
}

Status ApiClient::sendRaw(std::string_view bytes) {
  if (broken_) return Error{"connection is broken"};
  bool done = false;
  asio::error_code ec;
  impl_->withStream([&](auto& stream) {
    asio::async_write(stream, asio::buffer(bytes.data(), bytes.size()), [&](const asio::error_code& e, std::size_t) {
      ec = e;
      done = true;
    });
  });
  // A partial write leaves the stream mid-frame: a timeout breaks the connection.
  if (!impl_->runUntil(done, Clock::now() + config_.timeout)) {
    return fail("sending timed out after " + ms(config_.timeout));
  }
  if (ec) return fail("send failed: " + ec.message());
  return {};
}

Result<std::uint64_t> ApiClient::send(v1::Envelope envelope) {
  if (envelope.request_id() == 0) envelope.set_request_id(next_id_++);
  auto frame = api::encodeFrame(envelope);
  if (!frame) return frame.error();
  if (Status s = sendRaw(*frame); !s.ok()) return s.error();
  return envelope.request_id();
}

Result<v1::Envelope> ApiClient::receive(std::chrono::milliseconds timeout) {
  timed_out_ = false;
  if (broken_) return Error{"connection is broken"};
  const Clock::time_point deadline = Clock::now() + timeout;
  for (;;) {
    api::FrameResult r = impl_->decoder.next();
    if (auto* e = std::get_if<v1::Envelope>(&r)) return std::move(*e);
    if (const auto* err = std::get_if<api::FrameError>(&r)) return fail("bad frame from the server: " + err->message);
    bool done = false;
    asio::error_code ec;
    std::size_t n = 0;
    impl_->withStream([&](auto& stream) {
      stream.async_read_some(asio::buffer(impl_->buf), [&](const asio::error_code& e, std::size_t k) {
        ec = e;
        n = k;
        done = true;
      });
    });
    if (!impl_->runUntil(done, deadline)) {
      timed_out_ = true;
      return Error{"no frame from the server within " + ms(timeout)};
    }
    if (ec) {
      // A TLS peer that closes without close_notify reads as a truncated stream.
      const bool closed = ec == asio::error::eof || ec == asio::ssl::error::stream_truncated;
      return fail(closed ? std::string("the server closed the connection") : "receive failed: " + ec.message());
    }
    bytes_received_ += n;
    impl_->decoder.feed(std::span<const std::uint8_t>(impl_->buf.data(), n));
  }
}

Result<v1::Envelope> ApiClient::awaitResponse(std::uint64_t id) {
  for (;;) {
    auto r = receive(config_.timeout);
    if (!r) return r.error();
    v1::Envelope& e = *r;
    const auto body = e.body_case();
    if (isStream(body)) {
      if (streams_.size() >= config_.max_buffered_streams) {
        streams_.pop_front();
        ++dropped_streams_;
      }
      streams_.push_back(std::move(e));
      continue;
    }
    if (e.request_id() == id || (e.request_id() == 0 && body == v1::Envelope::kError)) {
      if (body == v1::Envelope::kError) {
        last_server_error_ = {e.error().code(), e.error().message()};
        return toError(e.error());
      }
      return std::move(e);
    }
    // A late reply to an earlier call that timed out: not ours.
  }
}

Result<v1::Envelope> ApiClient::call(v1::Envelope request) {
  request.set_request_id(next_id_++);
  auto id = send(std::move(request));
  if (!id) return id.error();
  return awaitResponse(*id);
}

Result<ServerInfo> ApiClient::hello() {
  v1::Envelope req;
  req.mutable_hello()->set_client_name(config_.client_name);
  req.mutable_hello()->set_protocol_version(api::kProtocolVersion);
  auto r = call(std::move(req));
  if (!r) return r.error();
  if (!r->has_hello_response()) return Error{"hello: the server answered with another message"};
  const auto& h = r->hello_response();
  auto role = api::fromProto(h.role());
  if (!role) return role.error();
  return ServerInfo{h.protocol_version(), h.server_name(), h.max_frame_bytes(), *role, h.operator_enabled()};
}

Result<api::Role> ApiClient::authenticate(std::string_view secret, std::string_view client_nonce) {
  v1::Envelope req;
  req.mutable_hello()->set_client_name(config_.client_name);
  req.mutable_hello()->set_protocol_version(api::kProtocolVersion);
  auto r = call(std::move(req));
  if (!r) return r.error();
  if (!r->has_hello_response()) return Error{"hello: the server answered with another message"};
  if (!r->hello_response().operator_enabled()) return Error{"the server has the operator role disabled"};
  const std::string server_nonce = r->hello_response().server_nonce();
  if (server_nonce.size() != api::kNonceBytes) {
    return Error{"the server's nonce is " + std::to_string(server_nonce.size()) + " bytes, not 32"};
  }
  std::string nonce(client_nonce);
  if (nonce.empty()) {
    api::SystemNonceSource source;
    auto drawn = source.nonce(api::kNonceBytes);
    if (!drawn) return drawn.error();
    nonce = std::move(*drawn);
  }
  if (nonce.size() != api::kNonceBytes) return Error{"client nonce must be 32 bytes"};
  v1::Envelope answer;
  answer.mutable_challenge_response()->set_client_nonce(nonce);
  answer.mutable_challenge_response()->set_mac(std::string(api::asBytes(api::clientMac(secret, server_nonce, nonce))));
  auto result = call(std::move(answer));
  if (!result) return result.error();
  if (!result->has_auth_result()) return Error{"authentication: the server answered with another message"};
  // Mutual: a server that does not know the secret cannot produce the proof.
  if (!api::macEquals(result->auth_result().server_proof(), api::serverProof(secret, server_nonce, nonce))) {
    return Error{"the server's proof is wrong: it does not know the secret"};
  }
  return api::fromProto(result->auth_result().role());
}

Result<api::StatusReport> ApiClient::status() {
  v1::Envelope req;
  req.mutable_get_status();
  auto r = call(std::move(req));
  if (!r) return r.error();
  if (!r->has_status()) return Error{"status: the server answered with another message"};
  return api::fromProto(r->status());
}

Result<api::Subscriptions> ApiClient::subscribe(const api::Subscriptions& subscriptions) {
  v1::Envelope req;
  req.mutable_subscribe()->set_waypoints(subscriptions.waypoints);
  req.mutable_subscribe()->set_poses(subscriptions.poses);
  req.mutable_subscribe()->set_status(subscriptions.status);
  req.mutable_subscribe()->set_graph(subscriptions.graph);
  auto r = call(std::move(req));
  if (!r) return r.error();
  if (!r->has_subscribed()) return Error{"subscribe: the server answered with another message"};
  return api::Subscriptions{r->subscribed().waypoints(), r->subscribed().poses(), r->subscribed().status(),
                            r->subscribed().graph()};
}

Result<std::vector<api::SubmapInfo>> ApiClient::submaps() {
  v1::Envelope req;
  req.mutable_list_submaps();
  auto r = call(std::move(req));
  if (!r) return r.error();
  if (!r->has_submap_list()) return Error{"submaps: the server answered with another message"};
  std::vector<api::SubmapInfo> out;
  for (const auto& s : r->submap_list().submaps()) {
    auto info = api::fromProto(s);
    if (!info) return info.error();
    out.push_back(*info);
  }
  return out;
}

Result<api::MissionState> ApiClient::command(const api::MissionCommand& command) {
  v1::Envelope req;
  api::toProto(command, *req.mutable_mission_command());
  auto r = call(std::move(req));
  if (!r) return r.error();
  if (!r->has_command_result()) return Error{"command: the server answered with another message"};
  return api::fromProto(r->command_result().mission_state());
}

Result<std::string> ApiClient::configText() {
  v1::Envelope req;
  req.mutable_get_config();
  auto r = call(std::move(req));
  if (!r) return r.error();
  if (!r->has_config_text()) return Error{"config: the server answered with another message"};
  return r->config_text().text();
}

namespace {

// Index and count of a chunk of a chunked transfer (map.proto MapChunk, api.proto CloudChunk, SubmapChunk).
struct ChunkHeader {
  std::uint32_t index = 0;
  std::uint32_t count = 0;
};

ChunkHeader chunkHeader(const v1::Envelope& e) {
  if (e.has_map_chunk()) return {e.map_chunk().chunk_index(), e.map_chunk().chunk_count()};
  if (e.has_cloud_chunk()) return {e.cloud_chunk().chunk_index(), e.cloud_chunk().chunk_count()};
  if (e.has_submap_chunk()) return {e.submap_chunk().chunk_index(), e.submap_chunk().chunk_count()};
  return {};
}

}  // namespace

Status ApiClient::receiveChunks(v1::Envelope request, const char* what, v1::Envelope::BodyCase chunk_body,
                                const std::function<Status(v1::Envelope&, std::uint32_t index)>& take) {
  request.set_request_id(next_id_++);
  auto id = send(std::move(request));
  if (!id) return id.error();
  // proto/README.md: chunks 0 .. count-1 in order, each announcing the same count (at least 1).
  std::uint32_t expected = 0;
  std::uint32_t count = 0;
  do {
    auto r = awaitResponse(*id);
    if (!r) return r.error();
    if (r->body_case() != chunk_body) return Error{std::string(what) + ": the server answered with another message"};
    const ChunkHeader h = chunkHeader(*r);
    if (h.index != expected || (expected > 0 && h.count != count) || h.count == 0) {
      return Error{std::string(what) + ": chunk " + std::to_string(h.index) + " of " + std::to_string(h.count) +
                   " arrived, expected chunk " + std::to_string(expected)};
    }
    count = h.count;
    if (Status s = take(*r, expected); !s.ok()) return s;
    ++expected;
  } while (expected < count);
  return {};
}

Status ApiClient::fetchMap(api::MapMirror& mirror, const ProgressFn& progress, std::uint32_t max_blocks_per_chunk) {
  v1::Envelope req;
  req.mutable_get_map()->set_since_version(mirror.version());
  req.mutable_get_map()->set_max_blocks_per_chunk(max_blocks_per_chunk);
  v1::MapDelta combined;
  const Status received = receiveChunks(
      std::move(req), "map", v1::Envelope::kMapChunk, [&](v1::Envelope& e, std::uint32_t index) -> Status {
        v1::MapChunk& chunk = *e.mutable_map_chunk();
        v1::MapDelta& part = *chunk.mutable_delta();
        if (index == 0) {
          *combined.mutable_grid() = part.grid();
          combined.set_since_version(part.since_version());
          combined.set_version(part.version());
          combined.set_n_submaps(part.n_submaps());
          combined.mutable_changed()->Reserve(
              static_cast<int>(std::min<std::uint64_t>(chunk.blocks_total(), 1u << 24)));
        } else if (part.version() != combined.version() || part.since_version() != combined.since_version()) {
          return Error{"map: chunk " + std::to_string(index) + " belongs to another version"};
        }
        for (auto& b : *part.mutable_removed()) combined.add_removed()->Swap(&b);
        for (auto& b : *part.mutable_changed()) combined.add_changed()->Swap(&b);
        if (progress) progress(static_cast<std::uint64_t>(combined.changed_size()), chunk.blocks_total());
        return {};
      });
  if (!received.ok()) return received;
  return mirror.apply(combined);
}

Result<api::GraphUpdate> ApiClient::graph() {
  v1::Envelope req;
  req.mutable_get_graph();
  auto r = call(std::move(req));
  if (!r) return r.error();
  if (!r->has_graph()) return Error{"get_graph: the server answered with another message"};
  auto g = api::fromProto(r->graph());
  if (!g) return g.error();
  if (!g->full) return Error{"get_graph: the server answered with a partial update"};
  return std::move(g).value();
}

Result<std::unique_ptr<map::LocalGrid>> ApiClient::fetchSubmap(std::uint32_t id, std::uint32_t max_bytes_per_chunk) {
  v1::Envelope req;
  req.mutable_get_submap()->set_id(id);
  req.mutable_get_submap()->set_max_bytes_per_chunk(max_bytes_per_chunk);
  api::SubmapAssembler assembler(id);
  const Status received =
      receiveChunks(std::move(req), "submap", v1::Envelope::kSubmapChunk,
                    [&](v1::Envelope& e, std::uint32_t) { return assembler.take(e.submap_chunk()); });
  if (!received.ok()) return received.error();
  return assembler.finish();
}

Result<api::Cloud> ApiClient::cloud(const ProgressFn& progress) {
  // vogd builds a reconstruction once one is asked for: the first request after a new map may be
  // answered UNAVAILABLE for a moment. Ask again for a while before giving up.
  const Clock::time_point give_up = Clock::now() + std::chrono::seconds(5);
  for (;;) {
    last_server_error_ = {};
    auto cloud = cloudOnce(progress);
    if (cloud || last_server_error_.code != v1::ERROR_CODE_UNAVAILABLE || Clock::now() >= give_up) return cloud;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

Result<api::Cloud> ApiClient::cloudOnce(const ProgressFn& progress) {
  v1::Envelope req;
  req.mutable_get_cloud();
  api::Cloud out;
  std::uint64_t total = 0;
  const Status received = receiveChunks(
      std::move(req), "cloud", v1::Envelope::kCloudChunk, [&](v1::Envelope& e, std::uint32_t index) -> Status {
        const v1::CloudChunk& chunk = e.cloud_chunk();
        total = chunk.points_total();
        if (chunk.xyz_m_size() % 3 != 0 || (chunk.normals_size() != 0 && chunk.normals_size() != chunk.xyz_m_size())) {
          return Error{"cloud: chunk " + std::to_string(index) + " has " + std::to_string(chunk.xyz_m_size()) +
                       " coordinates and " + std::to_string(chunk.normals_size()) + " normal components"};
        }
        for (int i = 0; i + 2 < chunk.xyz_m_size(); i += 3) {
          api::CloudPoint p;
          p.p_world_m = {chunk.xyz_m(i), chunk.xyz_m(i + 1), chunk.xyz_m(i + 2)};
          if (chunk.normals_size() != 0) {
            p.normal_world = {chunk.normals(i), chunk.normals(i + 1), chunk.normals(i + 2)};
          }
          out.push_back(p);
        }
        if (out.size() > total) return Error{"cloud: more points than the announced " + std::to_string(total)};
        if (progress) progress(out.size(), total);
        return {};
      });
  if (!received.ok()) return received.error();
  if (out.size() != total) {
    return Error{"cloud: " + std::to_string(out.size()) + " points received, " + std::to_string(total) + " announced"};
  }
  return out;
}

Result<StreamMessage> ApiClient::nextStream(std::chrono::milliseconds timeout) {
  timed_out_ = false;
  const Clock::time_point deadline = Clock::now() + timeout;
  for (;;) {
    if (!streams_.empty()) {
      v1::Envelope e = std::move(streams_.front());
      streams_.pop_front();
      if (e.has_waypoint()) {
        auto w = api::fromProto(e.waypoint());
        if (!w) return w.error();
        return StreamMessage{*w};
      }
      if (e.has_pose_update()) {
        auto p = api::fromProto(e.pose_update());
        if (!p) return p.error();
        return StreamMessage{*p};
      }
      if (e.has_graph_update()) {
        auto g = api::fromProto(e.graph_update());
        if (!g) return g.error();
        return StreamMessage{std::move(*g)};
      }
      auto s = api::fromProto(e.status_update());
      if (!s) return s.error();
      return StreamMessage{std::move(*s)};
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) {
      timed_out_ = true;
      return Error{"no stream message within " + ms(timeout)};
    }
    auto r = receive(left);
    if (!r) return r.error();
    const auto body = r->body_case();
    if (isStream(body)) {
      streams_.push_back(std::move(*r));
    } else if (body == v1::Envelope::kError) {
      last_server_error_ = {r->error().code(), r->error().message()};
      return toError(r->error());
    }
  }
}

}  // namespace vog::client
