#include "vog/api/auth.hpp"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>

#include <cassert>
#include <climits>

namespace vog::api {

Mac hmacSha256(std::string_view key, std::string_view message) {
  Mac out{};
  unsigned int len = 0;
  // One-shot HMAC (OpenSSL): cannot fail for SHA-256 with in-memory inputs below INT_MAX bytes.
  assert(key.size() < INT_MAX && message.size() < INT_MAX);
  const unsigned char* r =
      HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()),
           reinterpret_cast<const unsigned char*>(message.data()), message.size(), out.data(), &len);
  assert(r != nullptr && len == kMacBytes);
  (void)r;
  return out;
}

Mac clientMac(std::string_view secret, std::string_view server_nonce, std::string_view client_nonce) {
  std::string message;
  message.reserve(server_nonce.size() + client_nonce.size() + kClientMacLabel.size());
  message.append(server_nonce).append(client_nonce).append(kClientMacLabel);
  return hmacSha256(secret, message);
}

Mac serverProof(std::string_view secret, std::string_view server_nonce, std::string_view client_nonce) {
  std::string message;
  message.reserve(server_nonce.size() + client_nonce.size() + kServerProofLabel.size());
  message.append(client_nonce).append(server_nonce).append(kServerProofLabel);
  return hmacSha256(secret, message);
}

bool macEquals(std::string_view received, const Mac& expected) {
  if (received.size() != expected.size()) return false;  // the length is public (always 32)
  return CRYPTO_memcmp(received.data(), expected.data(), expected.size()) == 0;
}

std::string_view asBytes(const Mac& mac) { return {reinterpret_cast<const char*>(mac.data()), mac.size()}; }

Result<std::string> SystemNonceSource::nonce(std::size_t n_bytes) {
  std::string out(n_bytes, '\0');
  if (n_bytes > INT_MAX || RAND_bytes(reinterpret_cast<unsigned char*>(out.data()), static_cast<int>(n_bytes)) != 1) {
    return Error{"RAND_bytes failed to produce a " + std::to_string(n_bytes) + "-byte nonce"};
  }
  return out;
}

Result<std::string> SeededNonceSource::nonce(std::size_t n_bytes) {
  std::string out(n_bytes, '\0');
  for (std::size_t i = 0; i < n_bytes; i += 8) {
    std::uint64_t v = rng_();
    for (std::size_t k = 0; k < 8 && i + k < n_bytes; ++k, v >>= 8) out[i + k] = static_cast<char>(v & 0xFF);
  }
  return out;
}

std::string toHex(std::string_view bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(bytes.size() * 2);
  for (const char c : bytes) {
    const auto b = static_cast<unsigned char>(c);
    out += kDigits[b >> 4];
    out += kDigits[b & 0xF];
  }
  return out;
}

}  // namespace vog::api
