// ApiServer and ApiClient over real loopback sockets, with a real MergedMap behind the backend.
#include "vog/api/api_server.hpp"
#include "vog/api/framing.hpp"
#include "vog/client/api_client.hpp"

#include "api_test_support.hpp"
#include "fake_backend.hpp"
#include "test_support.hpp"

#include <asio.hpp>
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <sys/wait.h>

#include <condition_variable>
#include <cstdio>
#include <map>
#include <mutex>
#include <thread>

namespace vog::api {
namespace {

using namespace std::chrono_literals;
using client::ApiClient;
using test::expectMirrorEquals;
using test::kOperatorSecret;
using tcp = asio::ip::tcp;

ApiServerConfig defaultConfig() {
  ApiServerConfig c;
  c.dispatch.operator_secret = kOperatorSecret;
  c.dispatch.server_name = "vogd-test";
  c.dispatch.max_frame_bytes = 1u << 20;
  c.close_timeout = 500ms;
  return c;
}

class ApiServerTest : public ::testing::Test {
 protected:
  void start(const ApiServerConfig& config = defaultConfig()) {
    server_ = ApiServer::create(io_, backend_, config, &logger_, std::make_unique<SeededNonceSource>(11)).value();
    port_ = server_->listen("127.0.0.1", 0).value();
    thread_ = std::thread([this] { io_.run(); });
  }
  void TearDown() override {
    if (!server_) return;
    server_->stop();
    asio::post(io_, [this] { io_.stop(); });
    thread_.join();
  }
  std::unique_ptr<ApiClient> connect(client::ClientConfig config = {}) {
    config.timeout = 5s;
    auto c = ApiClient::connect("127.0.0.1", port_, config);
    EXPECT_TRUE(c.ok()) << (c.ok() ? "" : c.error().message);
    return c.ok() ? std::move(*c) : nullptr;
  }
  // Waits until the server closes `c`'s connection (a receive fails with "closed").
  static bool closedByServer(ApiClient& c) {
    for (int i = 0; i < 50; ++i) {
      auto r = c.receive(2s);
      if (!r.ok()) return c.broken();
    }
    return false;
  }
  // Waits for a condition on the server's stats (updated on its thread).
  template <class Pred>
  bool eventually(Pred pred) {
    for (int i = 0; i < 400; ++i) {
      if (pred(server_->stats())) return true;
      std::this_thread::sleep_for(5ms);
    }
    return false;
  }

  test::FakeBackend backend_;
  test::RecordingLogger logger_;
  asio::io_context io_;
  std::unique_ptr<ApiServer> server_;
  std::uint16_t port_ = 0;
  std::thread thread_;
};

TEST_F(ApiServerTest, EveryReadCallRoundTrips) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);

  const auto info = c->hello().value();
  EXPECT_EQ(info.protocol_version, 1u);
  EXPECT_EQ(info.server_name, "vogd-test");
  EXPECT_EQ(info.max_frame_bytes, 1u << 20);
  EXPECT_EQ(info.role, Role::kObserver);
  EXPECT_TRUE(info.operator_enabled);

  const StatusReport want = backend_.status();
  const StatusReport got = c->status().value();
  EXPECT_EQ(got.stamp_ns, want.stamp_ns);
  EXPECT_EQ(got.mission_state, want.mission_state);
  EXPECT_TRUE(got.T_world_vehicle.isApprox(want.T_world_vehicle, 1e-12));
  EXPECT_EQ(got.sigma_xyz_m, want.sigma_xyz_m);
  EXPECT_EQ(got.sigma_yaw_rad, want.sigma_yaw_rad);
  ASSERT_EQ(got.devices.size(), 2u);
  EXPECT_EQ(got.devices[1].name, "sonar");
  EXPECT_EQ(got.devices[1].state, DeviceState::kDegraded);
  EXPECT_EQ(got.devices[1].detail, "3 frames late");
  EXPECT_EQ(got.devices[1].errors, 3u);
  EXPECT_EQ(got.devices[0].last_stamp_ns, 123'000'000'000);
  EXPECT_EQ(got.n_submaps, 3u);
  EXPECT_EQ(got.n_closures, 1u);
  EXPECT_EQ(got.planner_state, PlannerState::kFollowing);
  EXPECT_EQ(got.map_version, backend_.mapSnapshot()->version());

  const auto want_submaps = backend_.submaps();
  const auto got_submaps = c->submaps().value();
  ASSERT_EQ(got_submaps.size(), want_submaps.size());
  for (std::size_t i = 0; i < want_submaps.size(); ++i) {
    EXPECT_EQ(got_submaps[i].id, want_submaps[i].id);
    EXPECT_TRUE(got_submaps[i].T_world_submap.isApprox(want_submaps[i].T_world_submap, 1e-12));
    EXPECT_EQ(got_submaps[i].n_scans, want_submaps[i].n_scans);
    EXPECT_EQ(got_submaps[i].n_scans, 15u);
    EXPECT_EQ(got_submaps[i].last_stamp_ns, want_submaps[i].last_stamp_ns);
    EXPECT_TRUE(got_submaps[i].closed);
  }

  std::vector<std::pair<std::uint64_t, std::uint64_t>> progress;
  const Cloud cloud = c->cloud([&](std::uint64_t n, std::uint64_t total) { progress.emplace_back(n, total); }).value();
  const Cloud& want_cloud = backend_.cloudData();
  ASSERT_EQ(cloud.size(), want_cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    ASSERT_EQ(cloud[i].p_world_m, want_cloud[i].p_world_m);
    ASSERT_EQ(cloud[i].normal_world, want_cloud[i].normal_world);
  }
  ASSERT_FALSE(progress.empty());
  EXPECT_EQ(progress.back(), std::make_pair(std::uint64_t{1000}, std::uint64_t{1000}));

  EXPECT_EQ(c->configText().value(), backend_.configText());
  const Subscriptions s = c->subscribe({true, false, true}).value();
  EXPECT_TRUE(s.waypoints);
  EXPECT_FALSE(s.poses);
  EXPECT_TRUE(s.status);
}

TEST_F(ApiServerTest, OperatorCommandsDriveTheMissionAfterAuthentication) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);
  ASSERT_EQ(c->authenticate(kOperatorSecret).value(), Role::kOperator);

  MissionCommand set_box;
  set_box.kind = MissionCommand::Kind::kSetBox;
  set_box.box.min_world_m = {-6.0, -6.5, -4.0};
  set_box.box.max_world_m = {6.0, 6.25, -0.5};
  EXPECT_EQ(c->command(set_box).value(), MissionState::kIdle);
  EXPECT_EQ(backend_.box().min_world_m, set_box.box.min_world_m);
  EXPECT_EQ(backend_.box().max_world_m, set_box.box.max_world_m);

  using K = MissionCommand::Kind;
  const std::vector<std::pair<K, MissionState>> steps = {{K::kStart, MissionState::kExploring},
                                                         {K::kPause, MissionState::kPaused},
                                                         {K::kResume, MissionState::kExploring},
                                                         {K::kReturnHome, MissionState::kReturning},
                                                         {K::kAbort, MissionState::kAborted}};
  for (const auto& [kind, state] : steps) {
    MissionCommand cmd;
    cmd.kind = kind;
    EXPECT_EQ(c->command(cmd).value(), state) << toString(kind);
  }
  EXPECT_EQ(c->status().value().mission_state, MissionState::kAborted);

  // The mission refuses a command in the wrong state: REJECTED with the backend's reason.
  MissionCommand resume;
  resume.kind = K::kResume;
  const auto refused = c->command(resume);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(c->lastServerError().code, v1::ERROR_CODE_REJECTED);
  EXPECT_NE(refused.error().message.find("resume while aborted"), std::string::npos) << refused.error().message;

  // An invalid box never reaches the backend.
  MissionCommand bad_box = set_box;
  bad_box.box.max_world_m.x() = -7.0;
  const auto invalid = c->command(bad_box);
  ASSERT_FALSE(invalid.ok());
  EXPECT_EQ(c->lastServerError().code, v1::ERROR_CODE_INVALID_ARGUMENT);
  EXPECT_NE(invalid.error().message.find("min_x_m"), std::string::npos) << invalid.error().message;
  EXPECT_EQ(backend_.commands().size(), 6u);
}

TEST_F(ApiServerTest, MapThroughTheClientEqualsTheServersMapFullThenIncremental) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);
  MapMirror mirror;
  std::vector<std::uint64_t> received;
  std::uint64_t total = 0;
  const auto progress = [&](std::uint64_t n, std::uint64_t t) {
    received.push_back(n);
    total = t;
  };
  // Small chunks: the transfer spans many frames.
  ASSERT_TRUE(c->fetchMap(mirror, progress, 16).ok());
  const auto first = backend_.mapSnapshot();
  expectMirrorEquals(mirror, *first);
  EXPECT_EQ(total, first->blockCount());
  ASSERT_GT(received.size(), 3u);
  EXPECT_TRUE(std::is_sorted(received.begin(), received.end()));
  EXPECT_EQ(received.back(), total);

  // A new submap and a loop closure that moves submap 0: the next fetch carries only what changed.
  backend_.addSubmap(5);
  backend_.moveSubmap(0, geometry::poseFromXyzRpy(0.3, -0.2, 0.05, 0.0, 0.0, 0.08));
  const auto second = backend_.mapSnapshot();
  ASSERT_GT(second->version(), first->version());
  received.clear();
  ASSERT_TRUE(c->fetchMap(mirror, progress).ok());
  expectMirrorEquals(mirror, *second);
  EXPECT_LT(total, second->blockCount()) << "blocks sent";
  EXPECT_GT(total, 0u);

  // The copy exports to OctoMap exactly as the server's map does (vogctl snapshot --out map.ot).
  EXPECT_EQ(mirror.knownVoxelCount(), second->knownVoxelCount());
  const auto mine = mirror.toOcTree().value();
  const auto theirs = second->toOcTree();
  EXPECT_EQ(mine->getNumLeafNodes(), theirs->getNumLeafNodes());
  for (auto it = theirs->begin_leafs(); it != theirs->end_leafs(); ++it) {
    const octomap::OcTreeNode* node = mine->search(it.getKey());
    ASSERT_NE(node, nullptr);
    ASSERT_EQ(node->getLogOdds(), it->getLogOdds());
  }

  // Up to date: an empty delta.
  ASSERT_TRUE(c->fetchMap(mirror, progress).ok());
  EXPECT_EQ(total, 0u);
  expectMirrorEquals(mirror, *second);

  // A version from the future (a restarted daemon) is refused, the mirror untouched.
  v1::Envelope req;
  req.mutable_get_map()->set_since_version(second->version() + 5);
  const std::uint64_t id = c->send(req).value();
  const v1::Envelope reply = c->receive(5s).value();
  EXPECT_EQ(reply.request_id(), id);
  ASSERT_TRUE(reply.has_error());
  EXPECT_EQ(reply.error().code(), v1::ERROR_CODE_INVALID_ARGUMENT);
}

TEST_F(ApiServerTest, AuthenticationSucceedsOnlyWithTheSecretAndEachNonceOnce) {
  start();
  auto wrong = connect();
  ASSERT_TRUE(wrong);
  const auto refused = wrong->authenticate("not-the-operator-secret");
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(wrong->lastServerError().code, v1::ERROR_CODE_AUTH_FAILED);
  EXPECT_TRUE(logger_.contains(LogLevel::kWarning, "authentication failed"));
  MissionCommand start_cmd;
  start_cmd.kind = MissionCommand::Kind::kStart;
  ASSERT_FALSE(wrong->command(start_cmd).ok());
  EXPECT_EQ(wrong->lastServerError().code, v1::ERROR_CODE_UNAUTHENTICATED);

  // A ChallengeResponse with no Hello before it.
  v1::Envelope stray;
  stray.mutable_challenge_response()->set_client_nonce(std::string(32, 'c'));
  stray.mutable_challenge_response()->set_mac(std::string(32, 'm'));
  (void)wrong->send(stray).value();
  const v1::Envelope no_challenge = wrong->receive(5s).value();
  ASSERT_TRUE(no_challenge.has_error());
  EXPECT_EQ(no_challenge.error().code(), v1::ERROR_CODE_AUTH_FAILED);

  // A correct answer replayed: the nonce was consumed by the first use.
  auto right = connect();
  ASSERT_TRUE(right);
  v1::Envelope hello;
  hello.mutable_hello()->set_protocol_version(1);
  (void)right->send(hello).value();
  const v1::Envelope challenge = right->receive(5s).value();
  ASSERT_TRUE(challenge.has_hello_response());
  const std::string server_nonce = challenge.hello_response().server_nonce();
  ASSERT_EQ(server_nonce.size(), 32u);
  const std::string client_nonce(32, '\x5a');
  v1::Envelope answer;
  answer.mutable_challenge_response()->set_client_nonce(client_nonce);
  answer.mutable_challenge_response()->set_mac(
      std::string(asBytes(clientMac(kOperatorSecret, server_nonce, client_nonce))));
  (void)right->send(answer).value();
  const v1::Envelope ok = right->receive(5s).value();
  ASSERT_TRUE(ok.has_auth_result());
  EXPECT_EQ(ok.auth_result().role(), v1::ROLE_OPERATOR);
  EXPECT_TRUE(macEquals(ok.auth_result().server_proof(), serverProof(kOperatorSecret, server_nonce, client_nonce)));
  (void)right->send(answer).value();
  const v1::Envelope replay = right->receive(5s).value();
  ASSERT_TRUE(replay.has_error());
  EXPECT_EQ(replay.error().code(), v1::ERROR_CODE_AUTH_FAILED);
  EXPECT_TRUE(right->command(start_cmd).ok() || right->lastServerError().code == v1::ERROR_CODE_REJECTED);
  EXPECT_TRUE(logger_.contains(LogLevel::kInfo, "authenticated as operator"));
}

TEST_F(ApiServerTest, CommandWithoutAuthenticationIsRefusedAndLogged) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);
  MissionCommand abort_cmd;
  abort_cmd.kind = MissionCommand::Kind::kAbort;
  const auto r = c->command(abort_cmd);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(c->lastServerError().code, v1::ERROR_CODE_UNAUTHENTICATED);
  EXPECT_NE(r.error().message.find("operator role"), std::string::npos) << r.error().message;
  EXPECT_TRUE(backend_.commands().empty());
  EXPECT_TRUE(logger_.contains(LogLevel::kWarning, "refused mission command KIND_ABORT"));
  // The session stays usable for reads.
  EXPECT_TRUE(c->status().ok());
}

struct Violation {
  const char* name;
  std::string bytes;
  v1::ErrorCode code;
};

std::vector<Violation> violations() {
  v1::Envelope response_as_request;
  response_as_request.set_request_id(4);
  response_as_request.mutable_status();
  return {
      {"malformed", std::string("\0\0\0\3\x0f\x01\x02", 7), v1::ERROR_CODE_MALFORMED_FRAME},
      {"oversize", std::string("\x7f\xff\xff\xff", 4), v1::ERROR_CODE_FRAME_TOO_LARGE},
      // request_id 7 and field 50 (a message type this server does not know) as a varint.
      {"unknown type", std::string("\0\0\0\5\x08\x07\x90\x03\x01", 9), v1::ERROR_CODE_UNKNOWN_MESSAGE},
      {"response as request", encodeFrame(response_as_request).value(), v1::ERROR_CODE_UNKNOWN_MESSAGE},
  };
}

TEST_F(ApiServerTest, ProtocolViolationsGetAnErrorAndDisconnectOnlyThatClient) {
  start();
  auto good = connect();
  ASSERT_TRUE(good);
  ASSERT_TRUE(good->subscribe({true, false, false}).ok());
  std::uint64_t n = 0;
  for (const Violation& v : violations()) {
    auto bad = connect();
    ASSERT_TRUE(bad);
    ASSERT_TRUE(bad->status().ok());
    ASSERT_TRUE(bad->sendRaw(v.bytes).ok());
    const auto err = bad->receive(5s);
    ASSERT_TRUE(err.ok()) << v.name;
    ASSERT_TRUE(err->has_error()) << v.name;
    EXPECT_EQ(err->error().code(), v.code) << v.name << ": " << err->error().message();
    EXPECT_TRUE(closedByServer(*bad)) << v.name;
    ++n;
    ASSERT_TRUE(eventually([&](const ApiServerStats& s) { return s.protocol_errors == n; })) << v.name;

    // The other client keeps working: calls and streams.
    EXPECT_TRUE(good->status().ok()) << v.name;
    Waypoint w;
    w.stamp_ns = static_cast<std::int64_t>(n);
    server_->publishWaypoint(w);
    const auto msg = good->nextStream(5s);
    ASSERT_TRUE(msg.ok()) << v.name;
    ASSERT_TRUE(std::holds_alternative<Waypoint>(*msg));
    EXPECT_EQ(std::get<Waypoint>(*msg).stamp_ns, static_cast<std::int64_t>(n));
  }
  EXPECT_TRUE(logger_.contains(LogLevel::kWarning, "exceeds the maximum"));
  EXPECT_EQ(server_->stats().clients, 1u);
}

TEST_F(ApiServerTest, ASlowReaderDoesNotHoldUpWaypointsForOthers) {
  ApiServerConfig config = defaultConfig();
  config.socket_send_buffer_bytes = 4096;
  config.max_queued_waypoints = 16;
  start(config);
  client::ClientConfig slow_config;
  slow_config.socket_receive_buffer_bytes = 4096;
  auto slow = connect(slow_config);
  auto fast = connect();
  ASSERT_TRUE(slow && fast);
  ASSERT_TRUE(slow->subscribe({true, false, false}).ok());
  ASSERT_TRUE(fast->subscribe({true, false, false}).ok());

  // The slow client reads nothing from here on. Each waypoint must reach the fast client at once,
  // in order and with nothing dropped, long after the slow client's socket buffers are full.
  constexpr int kN = 3000;
  for (int i = 1; i <= kN; ++i) {
    Waypoint w;
    w.stamp_ns = i;
    w.T_world_target = geometry::poseFromXyzRpy(0.001 * i, 2.0, -3.0, 0.0, 0.0, 0.25);
    w.speed_mps = 0.25;
    server_->publishWaypoint(w);
    const auto msg = fast->nextStream(5s);
    ASSERT_TRUE(msg.ok()) << i << ": " << msg.error().message;
    const auto& got = std::get<Waypoint>(*msg);
    ASSERT_EQ(got.seq, static_cast<std::uint64_t>(i));
    ASSERT_EQ(got.stamp_ns, i);
    ASSERT_EQ(got.dropped, 0u);
    ASSERT_TRUE(got.T_world_target.isApprox(w.T_world_target, 1e-12));
  }
  ASSERT_GT(server_->stats().stream_drops, 0u);

  // Now the slow client reads: every waypoint was either delivered or counted as dropped, the
  // oldest went first, and the newest arrived.
  std::uint64_t delivered = 0;
  std::uint64_t last_seq = 0;
  Waypoint last;
  while (last_seq < kN) {
    const auto msg = slow->nextStream(5s);
    ASSERT_TRUE(msg.ok()) << msg.error().message;
    last = std::get<Waypoint>(*msg);
    ASSERT_GT(last.seq, last_seq);
    last_seq = last.seq;
    ++delivered;
  }
  EXPECT_GT(last.dropped, 0u);
  EXPECT_EQ(delivered + last.dropped, static_cast<std::uint64_t>(kN));
  EXPECT_EQ(server_->stats().waypoint_drops, last.dropped);
  EXPECT_EQ(server_->stats().stream_drops, last.dropped);
  EXPECT_EQ(server_->stats().slow_disconnects, 0u);
}

TEST_F(ApiServerTest, PoseAndStatusStreamsFollowSubscriptions) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);
  ASSERT_TRUE(c->subscribe({false, true, true}).ok());
  Waypoint w;  // not subscribed: never arrives
  server_->publishWaypoint(w);
  PoseUpdate p;
  p.stamp_ns = 42;
  p.T_world_vehicle = geometry::poseFromXyzRpy(1.0, 2.0, -3.0, 0.1, -0.05, 2.5);
  server_->publishPose(p);
  const auto got_pose = c->nextStream(5s).value();
  ASSERT_TRUE(std::holds_alternative<PoseUpdate>(got_pose));
  EXPECT_EQ(std::get<PoseUpdate>(got_pose).stamp_ns, 42);
  EXPECT_EQ(std::get<PoseUpdate>(got_pose).seq, 1u);
  EXPECT_TRUE(std::get<PoseUpdate>(got_pose).T_world_vehicle.isApprox(p.T_world_vehicle, 1e-12));

  server_->publishStatus(backend_.status());
  const auto got_status = c->nextStream(5s).value();
  ASSERT_TRUE(std::holds_alternative<StatusUpdate>(got_status));
  EXPECT_EQ(std::get<StatusUpdate>(got_status).status.devices.size(), 2u);
  EXPECT_EQ(std::get<StatusUpdate>(got_status).status.n_submaps, 3u);

  ASSERT_TRUE(c->subscribe({false, false, false}).ok());
  server_->publishPose(p);
  EXPECT_FALSE(c->nextStream(200ms).ok());
}

TEST_F(ApiServerTest, AFullServerEvictsTheMostIdleObserverAndRefusesOnlyWhenAllAreOperators) {
  ApiServerConfig config = defaultConfig();
  config.max_clients = 2;
  start(config);
  auto a = connect();
  auto b = connect();
  ASSERT_TRUE(a && b);
  ASSERT_TRUE(a->status().ok());
  ASSERT_TRUE(b->status().ok());  // b asked last: a is the most idle
  auto c = connect();
  ASSERT_TRUE(c);
  EXPECT_TRUE(c->status().ok());
  const auto err = a->receive(5s);
  ASSERT_TRUE(err.ok());
  ASSERT_TRUE(err->has_error());
  EXPECT_EQ(err->error().code(), v1::ERROR_CODE_TOO_MANY_CLIENTS);
  EXPECT_NE(err->error().message().find("api.max_clients"), std::string::npos) << err->error().message();
  EXPECT_TRUE(closedByServer(*a));
  EXPECT_TRUE(b->status().ok());
  EXPECT_EQ(server_->stats().evicted, 1u);

  // Operators are never evicted: with both slots held by operators the newcomer is refused.
  ASSERT_EQ(b->authenticate(kOperatorSecret).value(), Role::kOperator);
  ASSERT_EQ(c->authenticate(kOperatorSecret).value(), Role::kOperator);
  auto extra = connect();
  ASSERT_TRUE(extra);
  const auto refused = extra->receive(5s);
  ASSERT_TRUE(refused.ok());
  ASSERT_TRUE(refused->has_error());
  EXPECT_EQ(refused->error().code(), v1::ERROR_CODE_TOO_MANY_CLIENTS);
  EXPECT_TRUE(closedByServer(*extra));
  EXPECT_TRUE(b->status().ok() && c->status().ok());
  EXPECT_EQ(server_->stats().refused_full, 1u);
  // A slot frees when a client leaves.
  c.reset();
  ASSERT_TRUE(eventually([](const ApiServerStats& s) { return s.clients == 1; }));
  auto again = connect();
  ASSERT_TRUE(again);
  EXPECT_TRUE(again->status().ok());
}

// Sends `n` GetStatus requests in one write and returns the error codes of the replies (0 = status).
std::vector<v1::ErrorCode> pipelined(ApiClient& c, int n) {
  std::string bytes;
  for (int i = 1; i <= n; ++i) {
    v1::Envelope e;
    e.set_request_id(static_cast<std::uint64_t>(1000 + i));
    e.mutable_get_status();
    bytes += encodeFrame(e).value();
  }
  EXPECT_TRUE(c.sendRaw(bytes).ok());
  std::vector<v1::ErrorCode> codes;
  for (int i = 1; i <= n; ++i) {
    auto r = c.receive(5s);
    if (!r.ok()) break;
    EXPECT_EQ(r->request_id(), static_cast<std::uint64_t>(1000 + i));
    codes.push_back(r->has_error() ? r->error().code() : v1::ERROR_CODE_UNSPECIFIED);
  }
  return codes;
}

TEST_F(ApiServerTest, RateAndInFlightLimitsRefuseRequestsWithAnError) {
  ApiServerConfig config = defaultConfig();
  config.max_requests_per_s = 0.5;
  config.request_burst = 5;
  start(config);
  auto c = connect();
  ASSERT_TRUE(c);
  const auto codes = pipelined(*c, 12);
  ASSERT_EQ(codes.size(), 12u);
  EXPECT_EQ(std::count(codes.begin(), codes.end(), v1::ERROR_CODE_UNSPECIFIED), 5);
  EXPECT_EQ(std::count(codes.begin(), codes.end(), v1::ERROR_CODE_RATE_LIMITED), 7);
}

TEST_F(ApiServerTest, InFlightLimitAndAReaderThatNeverReadsDisconnectOnlyTheFlooder) {
  ApiServerConfig config = defaultConfig();
  config.max_in_flight = 3;
  config.max_queued_responses = 8;
  config.socket_send_buffer_bytes = 4096;
  config.write_timeout = 300ms;
  start(config);
  client::ClientConfig flooder_config;
  flooder_config.socket_receive_buffer_bytes = 4096;
  auto polite = connect();
  auto flooder = connect(flooder_config);
  ASSERT_TRUE(polite && flooder);
  // Six requests in one segment: three answered, three refused as in flight.
  const auto codes = pipelined(*flooder, 6);
  ASSERT_EQ(codes.size(), 6u);
  EXPECT_EQ(std::count(codes.begin(), codes.end(), v1::ERROR_CODE_UNSPECIFIED), 3);
  EXPECT_EQ(std::count(codes.begin(), codes.end(), v1::ERROR_CODE_TOO_MANY_IN_FLIGHT), 3);
  // Thousands in one write, never read: the replies fill both socket buffers, the server stops
  // reading the flooder's requests, and with no write progress for write_timeout it disconnects it.
  std::string bytes;
  for (int i = 1; i <= 5000; ++i) {
    v1::Envelope e;
    e.set_request_id(static_cast<std::uint64_t>(i));
    e.mutable_get_status();
    bytes += encodeFrame(e).value();
  }
  ASSERT_TRUE(flooder->sendRaw(bytes).ok());
  ASSERT_TRUE(eventually([](const ApiServerStats& s) { return s.slow_disconnects == 1; }));
  EXPECT_TRUE(polite->status().ok());
  EXPECT_TRUE(logger_.contains(LogLevel::kWarning, "a client that does not read"));
  EXPECT_LE(server_->stats().max_session_queued_bytes, config.max_queued_bytes);
  EXPECT_TRUE(eventually([](const ApiServerStats& s) { return s.clients == 1 && s.queued_bytes == 0; }));
}

// More pipelined requests than any queue holds, in one write, from a client that reads: every one
// is answered (run, or refused with its id), in order, and the connection stays open.
TEST_F(ApiServerTest, ABurstOfPipelinedRequestsGetsOneReplyEach) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);
  constexpr int kN = 2000;
  const auto codes = pipelined(*c, kN);
  ASSERT_EQ(codes.size(), static_cast<std::size_t>(kN));
  for (const v1::ErrorCode code : codes) {
    EXPECT_TRUE(code == v1::ERROR_CODE_UNSPECIFIED || code == v1::ERROR_CODE_TOO_MANY_IN_FLIGHT ||
                code == v1::ERROR_CODE_RATE_LIMITED)
        << code;
  }
  EXPECT_GE(std::count(codes.begin(), codes.end(), v1::ERROR_CODE_UNSPECIFIED), 16);
  EXPECT_FALSE(c->broken());
  EXPECT_EQ(server_->stats().slow_disconnects, 0u);
  EXPECT_EQ(server_->stats().clients, 1u);
  // Still open: a later request is answered (the bucket has refilled a little by now, or it is
  // refused as rate limited: either way with its id).
  v1::Envelope e;
  e.mutable_get_status();
  const std::uint64_t id = c->send(e).value();
  const auto reply = c->receive(5s);
  ASSERT_TRUE(reply.ok()) << reply.error().message;
  EXPECT_EQ(reply->request_id(), id);
}

// Observers that ask for the whole map again and again and never read: each one's queue stays
// within its byte budget (nothing is encoded ahead), others are answered promptly, and the write
// timeout disconnects the stalled readers.
TEST_F(ApiServerTest, MapRequestsThatAreNeverReadStayWithinTheBudgetAndTimeOut) {
  ApiServerConfig config = defaultConfig();
  config.dispatch.max_frame_bytes = 64u << 10;
  config.dispatch.map_blocks_per_chunk = 4;
  config.dispatch.cloud_points_per_chunk = 2048;
  config.max_queued_bytes = 128u << 10;
  config.socket_send_buffer_bytes = 4096;
  config.write_timeout = 500ms;
  ASSERT_TRUE(config.validate().ok()) << config.validate().error().message;
  start(config);
  const auto snapshot = backend_.mapSnapshot();
  // One whole map alone is more than the budget (16 requests per client, several clients).
  ASSERT_GT(snapshot->blockCount() * 2000, config.max_queued_bytes) << "the map is too small";

  constexpr int kObservers = 4;
  client::ClientConfig stalled_config;
  stalled_config.socket_receive_buffer_bytes = 4096;
  std::vector<std::unique_ptr<ApiClient>> stalled;
  for (int i = 0; i < kObservers; ++i) {
    stalled.push_back(connect(stalled_config));
    ASSERT_TRUE(stalled.back());
    std::string bytes;
    for (int r = 1; r <= 16; ++r) {
      v1::Envelope e;
      e.set_request_id(static_cast<std::uint64_t>(r));
      e.mutable_get_map()->set_since_version(0);
      bytes += encodeFrame(e).value();
    }
    ASSERT_TRUE(stalled.back()->sendRaw(bytes).ok());
  }
  auto other = connect();
  ASSERT_TRUE(other);
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_TRUE(other->status().ok());
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);

  ASSERT_TRUE(eventually([](const ApiServerStats& s) { return s.slow_disconnects == kObservers; }))
      << server_->stats().slow_disconnects;
  const ApiServerStats s = server_->stats();
  EXPECT_GT(s.max_session_queued_bytes, 0u);
  EXPECT_LE(s.max_session_queued_bytes, config.max_queued_bytes);
  EXPECT_TRUE(eventually([](const ApiServerStats& st) { return st.clients == 1 && st.queued_bytes == 0; }));
  EXPECT_TRUE(other->status().ok());
  // A reader that reads still gets the whole map through the same budget.
  MapMirror mirror;
  ASSERT_TRUE(other->fetchMap(mirror).ok());
  expectMirrorEquals(mirror, *snapshot);
}

TEST_F(ApiServerTest, ConnectionsWithoutARequestAndIdleOnesAreClosedSubscribedOnesStay) {
  ApiServerConfig config = defaultConfig();
  config.hello_timeout = 200ms;
  config.idle_timeout = 1000ms;
  start(config);
  auto silent = connect();
  auto idle = connect();
  auto watcher = connect();
  ASSERT_TRUE(silent && idle && watcher);
  ASSERT_TRUE(idle->status().ok());
  ASSERT_TRUE(watcher->subscribe({true, false, false}).ok());
  // The silent connection gets an Error naming the setting, then is closed.
  const auto silent_err = silent->receive(5s);
  ASSERT_TRUE(silent_err.ok()) << silent_err.error().message;
  ASSERT_TRUE(silent_err->has_error());
  EXPECT_EQ(silent_err->error().code(), v1::ERROR_CODE_TIMED_OUT);
  EXPECT_NE(silent_err->error().message().find("api.hello_timeout_ms"), std::string::npos)
      << silent_err->error().message();
  EXPECT_TRUE(closedByServer(*silent));
  EXPECT_EQ(server_->stats().hello_timeouts, 1u);
  // The idle one goes after idle_timeout with an Error naming the setting; the subscribed one stays.
  const auto err = idle->receive(5s);
  ASSERT_TRUE(err.ok());
  ASSERT_TRUE(err->has_error());
  EXPECT_EQ(err->error().code(), v1::ERROR_CODE_TIMED_OUT);
  EXPECT_NE(err->error().message().find("api.idle_timeout_ms"), std::string::npos) << err->error().message();
  EXPECT_TRUE(closedByServer(*idle));
  EXPECT_EQ(server_->stats().idle_timeouts, 1u);
  Waypoint w;
  w.stamp_ns = 7;
  server_->publishWaypoint(w);
  const auto msg = watcher->nextStream(5s);
  ASSERT_TRUE(msg.ok()) << msg.error().message;
  EXPECT_EQ(std::get<Waypoint>(*msg).stamp_ns, 7);
  EXPECT_TRUE(watcher->status().ok());
}

TEST_F(ApiServerTest, FailedAuthenticationsFromOneAddressAreSlowedDown) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);
  for (int i = 0; i < 3; ++i) {
    ASSERT_FALSE(c->authenticate("not-the-operator-secret").ok());
    EXPECT_EQ(c->lastServerError().code, v1::ERROR_CODE_AUTH_FAILED);
  }
  EXPECT_TRUE(logger_.contains(LogLevel::kWarning, "3 failed authentications from 127.0.0.1; next attempt allowed in"));
  // Within the wait even the right secret is refused, from any connection of that address, with
  // the wait named; after it the right secret gets in.
  auto other = connect();
  ASSERT_TRUE(other);
  const auto refused = other->authenticate(kOperatorSecret);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(other->lastServerError().code, v1::ERROR_CODE_RATE_LIMITED);
  EXPECT_NE(refused.error().message.find("next attempt is allowed in"), std::string::npos) << refused.error().message;
  EXPECT_EQ(server_->stats().auth_failures, 3u);
  EXPECT_EQ(server_->stats().auth_throttled, 1u);
  std::this_thread::sleep_for(1100ms);  // the first wait is 1 s
  EXPECT_EQ(other->authenticate(kOperatorSecret).value(), Role::kOperator);
}

TEST(ApiServerConfigTest, ValidateNamesTheKeyAndValue) {
  ApiServerConfig c;
  EXPECT_TRUE(c.validate().ok());
  c.dispatch.operator_secret = "short";
  ASSERT_FALSE(c.validate().ok());
  EXPECT_NE(c.validate().error().message.find("api.operator_secret"), std::string::npos);
  c = {};
  c.max_clients = 0;
  EXPECT_NE(c.validate().error().message.find("api.max_clients: 0"), std::string::npos);
  c = {};
  c.dispatch.max_frame_bytes = 100;
  EXPECT_NE(c.validate().error().message.find("api.max_frame_bytes: 100"), std::string::npos);
  c = {};
  c.dispatch.map_blocks_per_chunk = 100000;
  EXPECT_NE(c.validate().error().message.find("api.map_blocks_per_chunk: 100000"), std::string::npos);
  c = {};
  c.max_requests_per_s = -1.0;
  EXPECT_NE(c.validate().error().message.find("api.max_requests_per_s"), std::string::npos);
  c = {};
  c.max_clients_per_peer = 0;
  EXPECT_NE(c.validate().error().message.find("api.max_clients_per_peer: 0 is outside [1, 4096]"), std::string::npos);
  c = {};
  c.hello_timeout = 50ms;
  EXPECT_NE(c.validate().error().message.find("api.hello_timeout_ms: 50 is outside [100, 600000]"), std::string::npos);
  c = {};
  c.idle_timeout = 0ms;
  EXPECT_NE(c.validate().error().message.find("api.idle_timeout_ms: 0"), std::string::npos);
  c = {};
  c.write_timeout = 700000ms;
  EXPECT_NE(c.validate().error().message.find("api.write_timeout_ms: 700000"), std::string::npos);
  c = {};
  c.max_queued_bytes = 1u << 20;  // below the 4 MiB frame
  EXPECT_NE(c.validate().error().message.find("api.max_queued_bytes: 1048576 is outside [max_frame_bytes 4194304"),
            std::string::npos)
      << c.validate().error().message;
}

}  // namespace
}  // namespace vog::api

namespace vog::api {
namespace {

// Runs vogctl with `args`, returns its exit code and stdout.
std::pair<int, std::string> vogctl(const std::string& args) {
  const std::string command = std::string(VOG_VOGCTL_PATH) + " " + args + " 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return {-1, ""};
  std::string out;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, pipe)) out.append(buf, n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

// 64 connections that never send and 64 that send one byte a second, all from one address, hold
// far more than the server's slots: the operator's vogctl still gets in, within a generous bound.
TEST_F(ApiServerTest, VogctlIsAnsweredWhileIdleAndSlowConnectionsHoldEverySlot) {
  start();  // the defaults: 64 clients, 16 per peer address
  asio::io_context io;
  const tcp::endpoint server(asio::ip::make_address("127.0.0.1"), port_);
  std::vector<tcp::socket> idle, slow;
  for (int i = 0; i < 64; ++i) {
    idle.emplace_back(io).connect(server);
    slow.emplace_back(io).connect(server);
  }
  ASSERT_TRUE(eventually([](const ApiServerStats& s) { return s.accepted + s.refused_full == 128; }));
  EXPECT_EQ(server_->stats().clients, 16u);

  std::mutex mutex;
  std::condition_variable cv;
  bool done = false;  // guarded by mutex
  std::thread trickle([&] {
    std::unique_lock lock(mutex);
    do {
      for (tcp::socket& s : slow) {
        asio::error_code ec;  // an evicted socket fails: fine
        (void)s.write_some(asio::buffer("\0", 1), ec);
      }
    } while (!cv.wait_for(lock, 1s, [&] { return done; }));
  });

  const vog::test::TempDir dir("vogctl-hostile");
  const auto secret = dir.path() / "secret";
  {
    std::FILE* f = std::fopen(secret.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs(kOperatorSecret, f);
    std::fclose(f);
  }
  const std::string port = " --port " + std::to_string(port_);
  auto t0 = std::chrono::steady_clock::now();
  const auto [abort_rc, abort_out] = vogctl("mission abort --secret-file " + secret.string() + port);
  const auto abort_time = std::chrono::steady_clock::now() - t0;
  t0 = std::chrono::steady_clock::now();
  const auto [status_rc, status_out] = vogctl("status --json" + port);
  const auto status_time = std::chrono::steady_clock::now() - t0;
  {
    std::lock_guard lock(mutex);
    done = true;
  }
  cv.notify_all();
  trickle.join();

  EXPECT_EQ(abort_rc, 0) << abort_out;
  EXPECT_LT(abort_time, 2s);
  ASSERT_FALSE(backend_.commands().empty());
  EXPECT_EQ(backend_.commands().back().kind, MissionCommand::Kind::kAbort);
  EXPECT_EQ(status_rc, 0) << status_out;
  EXPECT_LT(status_time, 2s);
  EXPECT_NE(status_out.find("\"mission_state\":\"aborted\""), std::string::npos) << status_out;
  EXPECT_GE(server_->stats().evicted, 128u - 16u);
}

TEST_F(ApiServerTest, VogctlStatusWatchAndSnapshot) {
  start();
  const std::string port = " --port " + std::to_string(port_);
  const auto [status_rc, status_out] = vogctl("status --json" + port);
  ASSERT_EQ(status_rc, 0);
  EXPECT_NE(status_out.find("\"mission_state\":\"idle\""), std::string::npos) << status_out;
  EXPECT_NE(status_out.find("\"n_submaps\":3"), std::string::npos) << status_out;
  EXPECT_NE(status_out.find("\"device\":\"sonar\",\"state\":\"degraded\""), std::string::npos) << status_out;

  // Wrong secret: authentication fails, non-zero exit.
  const vog::test::TempDir dir("vogctl");
  {
    std::FILE* f = std::fopen((dir.path() / "wrong").c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs("not-the-secret-at-all\n", f);
    std::fclose(f);
  }
  EXPECT_NE(vogctl("status --secret-file " + (dir.path() / "wrong").string() + port).first, 0);

  const auto bt = dir.path() / "map.bt";
  const auto [snap_rc, snap_out] = vogctl("snapshot --json --out " + bt.string() + port);
  ASSERT_EQ(snap_rc, 0) << snap_out;
  const auto snapshot = backend_.mapSnapshot();
  EXPECT_NE(snap_out.find("\"known_voxels\":" + std::to_string(snapshot->knownVoxelCount())), std::string::npos)
      << snap_out;
  octomap::OcTree read(0.1);
  ASSERT_TRUE(read.readBinary(bt.string()));
  EXPECT_EQ(read.getResolution(), snapshot->resolution());
  const auto theirs = snapshot->toOcTree();
  // .bt keeps occupancy only: every voxel's occupied/free state must match the server's map.
  std::size_t checked = 0;
  for (auto it = theirs->begin_leafs(); it != theirs->end_leafs(); ++it, ++checked) {
    const octomap::OcTreeNode* node = read.search(it.getKey());
    ASSERT_NE(node, nullptr);
    ASSERT_EQ(read.isNodeOccupied(node), theirs->isNodeOccupied(*it));
  }
  EXPECT_GT(checked, 1000u);
  EXPECT_NE(vogctl("snapshot --out " + (dir.path() / "map.png").string() + port).first, 0);

  // watch: two waypoints published while it runs.
  std::thread publisher([this] {
    bool seen = false;  // stop once vogctl has come and gone
    for (int i = 1; i <= 100; ++i) {
      std::this_thread::sleep_for(50ms);
      Waypoint w;
      w.stamp_ns = i * 1'000'000'000LL;
      w.T_world_target = geometry::poseFromXyzRpy(i, 0.0, -1.0, 0.0, 0.0, 0.0);
      server_->publishWaypoint(w);
      const bool connected = server_->stats().clients > 0;
      if (seen && !connected) break;
      seen = seen || connected;
    }
  });
  const auto [watch_rc, watch_out] = vogctl("watch --waypoints --count 2 --json" + port);
  publisher.join();
  EXPECT_EQ(watch_rc, 0);
  EXPECT_EQ(std::count(watch_out.begin(), watch_out.end(), '\n'), 2) << watch_out;
  EXPECT_NE(watch_out.find("\"stream\":\"waypoint\""), std::string::npos) << watch_out;
}

}  // namespace
}  // namespace vog::api

// ------------------------------------------------------------------ the VOG-Map as submaps (GetSubmap, graph)

namespace vog::api {
namespace {

using namespace std::chrono_literals;

// Waits for graph updates until `held` reaches the backend's graph version; every update must apply.
void followGraph(ApiClient& c, GraphState& held, std::uint64_t until_version, std::size_t* moved = nullptr) {
  while (held.version < until_version) {
    auto m = c.nextStream(5s);
    ASSERT_TRUE(m.ok()) << m.error().message;
    const auto* u = std::get_if<GraphUpdate>(&*m);
    if (u == nullptr) continue;
    if (moved != nullptr && !u->full) *moved += u->submaps.size() + u->moved.size();
    const auto st = applyGraphUpdate(held, *u);
    ASSERT_TRUE(st.ok()) << st.error().message;
  }
}

// Merges fetched grids at the held poses, as a topside mirror does (re-merge tolerance 0).
void mergeMirror(map::MergedMap& merged, const std::map<std::uint32_t, std::shared_ptr<const map::LocalGrid>>& grids,
                 const GraphState& graph) {
  std::vector<map::SubmapEntry> entries;
  for (const SubmapPose& p : graph.submaps) {
    entries.push_back({p.id, grids.at(p.id), p.T_world_submap, p.T_world_submap.inverse()});
  }
  map::MergeConfig exact;
  exact.remerge_translation_m = 0.0;
  exact.remerge_rotation_rad = 0.0;
  exact.threads = 1;
  ASSERT_TRUE(merged.sync(entries, exact).ok());
}

TEST_F(ApiServerTest, SubmapsFetchedOnceAndTheGraphStreamRebuildTheServersMapBitForBit) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);
  auto subscribed = c->subscribe({false, false, false, true});
  ASSERT_TRUE(subscribed.ok() && subscribed->graph);
  GraphState held;
  followGraph(*c, held, backend_.graph()->version);
  ASSERT_EQ(held.submaps.size(), 3u);

  std::map<std::uint32_t, std::shared_ptr<const map::LocalGrid>> grids;
  for (const SubmapPose& p : held.submaps) {
    auto grid = c->fetchSubmap(p.id, 4096);  // small slices: many chunks
    ASSERT_TRUE(grid.ok()) << grid.error().message;
    // The same tree: the .ot bytes of both grids are equal.
    EXPECT_EQ((*grid)->serialize().value(), backend_.submapGrid(p.id)->serialize().value());
    grids[p.id] = std::move(grid).value();
  }
  auto mirror = map::MergedMap::create(backend_.gridConfig()).value();
  mergeMirror(*mirror, grids, held);
  EXPECT_TRUE(mirror->sameVoxels(*backend_.mapSnapshot()));

  // A new submap, a loop closure moving submap 0, the closure itself: only those travel.
  backend_.addSubmap(3);
  server_->publishGraph();
  backend_.moveSubmap(0, geometry::poseFromXyzRpy(0.3, -0.2, 0.05, 0.0, 0.0, 0.08));
  backend_.addClosure(3, 0);
  server_->publishGraph();
  std::size_t moved = 0;
  followGraph(*c, held, backend_.graph()->version, &moved);
  EXPECT_EQ(moved, 2u) << "submap 3 (new) and submap 0 (moved)";
  ASSERT_EQ(held.closures.size(), 1u);
  EXPECT_EQ(held.closures[0], (ClosurePair{3, 0}));
  grids[3] = c->fetchSubmap(3).value();
  mergeMirror(*mirror, grids, held);
  EXPECT_TRUE(mirror->sameVoxels(*backend_.mapSnapshot()));
  EXPECT_EQ(mirror->knownVoxelCount(), backend_.mapSnapshot()->knownVoxelCount());

  // GetGraph answers the same graph whole.
  GraphState whole;
  ASSERT_TRUE(applyGraphUpdate(whole, c->graph().value()).ok());
  EXPECT_EQ(whole.version, held.version);
  ASSERT_EQ(whole.submaps.size(), held.submaps.size());
  for (std::size_t i = 0; i < whole.submaps.size(); ++i) {
    EXPECT_TRUE(whole.submaps[i].T_world_submap.matrix() == held.submaps[i].T_world_submap.matrix());
  }
}

TEST_F(ApiServerTest, AGraphClientThatFellBehindGetsOneUpdateSpanningWhatItMissed) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);
  ASSERT_TRUE(c->subscribe({false, false, false, true}).ok());
  GraphState held;
  followGraph(*c, held, backend_.graph()->version);
  const std::uint64_t before = held.version;
  // Three changes published while the client reads nothing.
  for (std::size_t i = 3; i < 6; ++i) {
    backend_.addSubmap(i);
    server_->publishGraph();
  }
  followGraph(*c, held, backend_.graph()->version);
  EXPECT_EQ(held.version, before + 3);
  EXPECT_EQ(held.submaps.size(), 6u);
}

TEST_F(ApiServerTest, GetSubmapRefusesUnknownIdsAndChunksLargerThanAFrame) {
  start();
  auto c = connect();
  ASSERT_TRUE(c);
  auto unknown = c->fetchSubmap(99);
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(c->lastServerError().code, v1::ERROR_CODE_INVALID_ARGUMENT);
  EXPECT_NE(unknown.error().message.find("99"), std::string::npos) << unknown.error().message;
  auto huge = c->fetchSubmap(0, 8u << 20);
  ASSERT_FALSE(huge.ok());
  EXPECT_EQ(c->lastServerError().code, v1::ERROR_CODE_INVALID_ARGUMENT);
  EXPECT_NE(huge.error().message.find("max_bytes_per_chunk"), std::string::npos) << huge.error().message;
  // The connection is still good.
  EXPECT_TRUE(c->fetchSubmap(1).ok());
}

}  // namespace
}  // namespace vog::api
