#pragma once
// Operator authentication by challenge-response over HMAC-SHA256 (RFC 2104, FIPS 180-4), layout in
// proto/README.md "Authentication". The shared secret never crosses the wire: the server sends a
// fresh random nonce, the client answers HMAC(secret, server_nonce || client_nonce || "vog.v1").

#include "vog/core/result.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <string_view>

namespace vog::api {

inline constexpr std::size_t kNonceBytes = 32;
inline constexpr std::size_t kMacBytes = 32;
inline constexpr std::string_view kClientMacLabel = "vog.v1";
inline constexpr std::string_view kServerProofLabel = "vog.v1 server";

using Mac = std::array<std::uint8_t, kMacBytes>;

// HMAC-SHA256(key, message).
Mac hmacSha256(std::string_view key, std::string_view message);
// The client's answer: HMAC(secret, server_nonce || client_nonce || "vog.v1").
Mac clientMac(std::string_view secret, std::string_view server_nonce, std::string_view client_nonce);
// The server's proof: HMAC(secret, client_nonce || server_nonce || "vog.v1 server").
Mac serverProof(std::string_view secret, std::string_view server_nonce, std::string_view client_nonce);
// Constant-time comparison (CRYPTO_memcmp): the time taken does not depend on where they differ.
bool macEquals(std::string_view received, const Mac& expected);
std::string_view asBytes(const Mac& mac);

// Where nonces come from: real randomness in production, a seed in tests (deterministic runs).
class NonceSource {
 public:
  virtual ~NonceSource() = default;
  virtual Result<std::string> nonce(std::size_t n_bytes) = 0;
};

// OpenSSL RAND_bytes (the OS CSPRNG).
class SystemNonceSource final : public NonceSource {
 public:
  Result<std::string> nonce(std::size_t n_bytes) override;
};

// A seeded generator; for tests and lockstep runs only (predictable nonces are replayable).
class SeededNonceSource final : public NonceSource {
 public:
  explicit SeededNonceSource(std::uint64_t seed) : rng_(seed) {}
  Result<std::string> nonce(std::size_t n_bytes) override;

 private:
  std::mt19937_64 rng_;
};

// Lower-case hex of bytes, for logs and the README's worked example.
std::string toHex(std::string_view bytes);

}  // namespace vog::api
