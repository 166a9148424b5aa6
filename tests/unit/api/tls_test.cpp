// The API over TLS (api.tls): certificates made here with OpenSSL (a self-signed P-256 certificate
// for localhost / 127.0.0.1 is its own CA), a real ApiServer and ApiClient on loopback.
#include "vog/api/api_server.hpp"
#include "vog/client/api_client.hpp"

#include "api_test_support.hpp"
#include "fake_backend.hpp"
#include "test_support.hpp"

#include <asio.hpp>
#include <gtest/gtest.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>

#include <chrono>
#include <cstdio>
#include <thread>
#include <vector>

namespace vog::api {
namespace {

using namespace std::chrono_literals;
using client::ApiClient;
using test::kOperatorSecret;

struct Certificate {
  std::filesystem::path certificate_file;
  std::filesystem::path key_file;
};

// A self-signed certificate for `common_name` with subject alternative names localhost and
// 127.0.0.1, valid for a day, and its key, written as PEM files `name`.pem and `name`.key.
Certificate makeSelfSigned(const std::filesystem::path& dir, const std::string& name, const std::string& common_name) {
  EVP_PKEY* key = EVP_PKEY_Q_keygen(nullptr, nullptr, "EC", "P-256");
  X509* x = X509_new();
  X509_set_version(x, 2);
  ASN1_INTEGER_set(X509_get_serialNumber(x), 1);
  X509_gmtime_adj(X509_getm_notBefore(x), -60);
  X509_gmtime_adj(X509_getm_notAfter(x), 24 * 3600);
  X509_set_pubkey(x, key);
  X509_NAME* subject = X509_get_subject_name(x);
  X509_NAME_add_entry_by_txt(subject, "CN", MBSTRING_ASC, reinterpret_cast<const unsigned char*>(common_name.c_str()),
                             -1, -1, 0);
  X509_set_issuer_name(x, subject);
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, x, x, nullptr, nullptr, 0);
  for (const auto& [nid, value] : {std::pair{NID_subject_alt_name, "DNS:localhost,IP:127.0.0.1"},
                                   std::pair{NID_basic_constraints, "critical,CA:TRUE"}}) {
    X509_EXTENSION* ext = X509V3_EXT_conf_nid(nullptr, &ctx, nid, value);
    X509_add_ext(x, ext, -1);
    X509_EXTENSION_free(ext);
  }
  X509_sign(x, key, EVP_sha256());
  Certificate c{dir / (name + ".pem"), dir / (name + ".key")};
  FILE* f = std::fopen(c.certificate_file.c_str(), "w");
  PEM_write_X509(f, x);
  std::fclose(f);
  f = std::fopen(c.key_file.c_str(), "w");
  PEM_write_PrivateKey(f, key, nullptr, nullptr, 0, nullptr, nullptr);
  std::fclose(f);
  X509_free(x);
  EVP_PKEY_free(key);
  return c;
}

class TlsTest : public ::testing::Test {
 protected:
  TlsTest() : dir_("vog-tls"), server_cert_(makeSelfSigned(dir_.path(), "server", "vogd")) {}

  ApiServerConfig tlsConfig() const {
    ApiServerConfig c;
    c.dispatch.operator_secret = kOperatorSecret;
    c.tls.certificate_chain_file = server_cert_.certificate_file;
    c.tls.private_key_file = server_cert_.key_file;
    c.tls.handshake_timeout = 500ms;
    return c;
  }
  void start(const ApiServerConfig& config) {
    server_ = ApiServer::create(io_, backend_, config, &logger_, std::make_unique<SeededNonceSource>(3)).value();
    port_ = server_->listen("127.0.0.1", 0).value();
    thread_ = std::thread([this] { io_.run(); });
  }
  void TearDown() override {
    if (!server_) return;
    server_->stop();
    asio::post(io_, [this] { io_.stop(); });
    thread_.join();
  }
  Result<std::unique_ptr<ApiClient>> connect(bool tls, const std::filesystem::path& ca,
                                             const std::string& host = "127.0.0.1") {
    client::ClientConfig c;
    c.timeout = 3s;
    c.tls.enabled = tls;
    c.tls.ca_file = ca;
    return ApiClient::connect(host, port_, c);
  }
  template <class Pred>
  bool eventually(Pred pred) {
    for (int i = 0; i < 400; ++i) {
      if (pred(server_->stats())) return true;
      std::this_thread::sleep_for(5ms);
    }
    return false;
  }

  vog::test::TempDir dir_;
  Certificate server_cert_;
  test::FakeBackend backend_;
  test::RecordingLogger logger_;
  asio::io_context io_;
  std::unique_ptr<ApiServer> server_;
  std::uint16_t port_ = 0;
  std::thread thread_;
};

TEST_F(TlsTest, ClientsThatVerifyTheServerTalkAndAuthenticateOverTls) {
  start(tlsConfig());
  for (const std::string host : {"127.0.0.1", "localhost"}) {
    auto c = connect(true, server_cert_.certificate_file, host);
    ASSERT_TRUE(c.ok()) << host << ": " << c.error().message;
    auto status = (*c)->status();
    ASSERT_TRUE(status.ok()) << status.error().message;
    EXPECT_EQ((*c)->authenticate(kOperatorSecret).value(), Role::kOperator);
    auto config = (*c)->configText();
    ASSERT_TRUE(config.ok());
    EXPECT_EQ(*config, backend_.configText());
  }
  EXPECT_EQ(server_->stats().tls_failures, 0u);
}

TEST_F(TlsTest, PlainClientsAndUntrustedServersAreRefused) {
  start(tlsConfig());
  // A plain TCP client: the server expects a handshake, gets a frame, and closes that client only.
  auto plain = connect(false, {});
  ASSERT_TRUE(plain.ok());
  EXPECT_FALSE((*plain)->status().ok());
  EXPECT_TRUE(eventually([](const ApiServerStats& s) { return s.tls_failures == 1; }));
  EXPECT_TRUE(logger_.contains(LogLevel::kWarning, "TLS handshake failed"));

  // A client that trusts another CA does not accept this server.
  const Certificate other = makeSelfSigned(dir_.path(), "other", "not-vogd");
  auto untrusted = connect(true, other.certificate_file);
  ASSERT_FALSE(untrusted.ok());
  EXPECT_NE(untrusted.error().message.find("TLS handshake with 127.0.0.1"), std::string::npos)
      << untrusted.error().message;
  EXPECT_NE(untrusted.error().message.find("certificate verify failed"), std::string::npos)
      << untrusted.error().message;
  // Nor a certificate for another name (the same certificate, asked for by another host name).
  auto misnamed = connect(true, server_cert_.certificate_file, "127.0.0.2");
  EXPECT_FALSE(misnamed.ok());

  // A client that never handshakes is closed after the handshake timeout.
  asio::io_context io;
  asio::ip::tcp::socket idle(io);
  idle.connect({asio::ip::make_address("127.0.0.1"), port_});
  EXPECT_TRUE(eventually([](const ApiServerStats& s) { return s.tls_failures >= 3; })) << server_->stats().tls_failures;

  // The server still serves verified clients.
  auto good = connect(true, server_cert_.certificate_file);
  ASSERT_TRUE(good.ok()) << good.error().message;
  EXPECT_TRUE((*good)->status().ok());
}

// Sockets that never handshake and handshaken sessions that never ask hold every slot (the default
// handshake timeout, 5 s): a verified client still gets in at once, by evicting the most idle.
TEST_F(TlsTest, UnhandshakenAndIdleSessionsDoNotKeepTheOperatorOut) {
  ApiServerConfig config = tlsConfig();
  config.tls.handshake_timeout = 5s;
  config.max_clients = 8;
  start(config);
  std::vector<std::unique_ptr<ApiClient>> idle;
  for (int i = 0; i < 4; ++i) {
    auto c = connect(true, server_cert_.certificate_file);
    ASSERT_TRUE(c.ok()) << c.error().message;
    idle.push_back(std::move(*c));
  }
  asio::io_context io;
  std::vector<asio::ip::tcp::socket> silent;
  for (int i = 0; i < 16; ++i) silent.emplace_back(io).connect({asio::ip::make_address("127.0.0.1"), port_});
  ASSERT_TRUE(eventually([](const ApiServerStats& s) { return s.accepted + s.refused_full == 20; }));
  EXPECT_EQ(server_->stats().clients, 8u);

  const auto t0 = std::chrono::steady_clock::now();
  auto good = connect(true, server_cert_.certificate_file);
  ASSERT_TRUE(good.ok()) << good.error().message;
  EXPECT_EQ((*good)->authenticate(kOperatorSecret).value(), Role::kOperator);
  EXPECT_TRUE((*good)->status().ok());
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2s);
  EXPECT_EQ(server_->stats().refused_full, 0u);
  EXPECT_GE(server_->stats().evicted, 13u);
}

// A flood of connections to a server whose slots are all held by operators: beyond twice
// max_clients open sockets, a refused connection is closed at once instead of waiting out its TLS
// handshake, so a flood cannot pile up sockets.
TEST_F(TlsTest, AFloodOfRefusedConnectionsIsClosedAtOnce) {
  ApiServerConfig config = tlsConfig();
  config.tls.handshake_timeout = 5s;
  config.max_clients = 2;
  start(config);
  std::vector<std::unique_ptr<ApiClient>> operators;
  for (int i = 0; i < 2; ++i) {
    auto c = connect(true, server_cert_.certificate_file);
    ASSERT_TRUE(c.ok()) << c.error().message;
    ASSERT_EQ((*c)->authenticate(kOperatorSecret).value(), Role::kOperator);
    operators.push_back(std::move(*c));
  }
  std::vector<std::unique_ptr<ApiClient>> flood;
  for (int i = 0; i < 20; ++i) {
    auto c = connect(false, {});
    ASSERT_TRUE(c.ok()) << c.error().message;
    flood.push_back(std::move(*c));
  }
  ASSERT_TRUE(eventually([](const ApiServerStats& s) { return s.refused_full == 20; }));
  int closed = 0;
  for (auto& c : flood) {
    const auto r = c->receive(100ms);
    closed += !r.ok() && c->broken() ? 1 : 0;
  }
  EXPECT_EQ(closed, 18);
  for (auto& c : operators) EXPECT_TRUE(c->status().ok());
}

TEST_F(TlsTest, BadCertificateFilesAreNamed) {
  ApiServerConfig c = tlsConfig();
  c.tls.certificate_chain_file = dir_.path() / "missing.pem";
  auto s = ApiServer::create(io_, backend_, c, &logger_);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("api.tls.certificate_file"), std::string::npos) << s.error().message;
  // The key of another certificate.
  const Certificate other = makeSelfSigned(dir_.path(), "other", "x");
  c = tlsConfig();
  c.tls.private_key_file = other.key_file;
  s = ApiServer::create(io_, backend_, c, &logger_);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("api.tls.private_key_file"), std::string::npos) << s.error().message;
  c = tlsConfig();
  c.tls.private_key_file.clear();
  s = ApiServer::create(io_, backend_, c, &logger_);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("api.tls.private_key_file"), std::string::npos) << s.error().message;
}

}  // namespace
}  // namespace vog::api
